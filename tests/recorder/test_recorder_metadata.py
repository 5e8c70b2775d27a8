"""The recording's metadata: one typed Struct, encoded and decoded in one place."""

from __future__ import annotations

import pytest
from oimi.recorder.errors import RecordingError
from oimi.recorder.metadata import OimiRecord, RecordingMetadata, ScenarioRecord, SessionRecord

RECORDS = {
    "oimi": {"format_version": "9", "recording_id": "greeting-7", "version": "1.0"},
    "scenario": {"name": "greeting", "file": "greeting.toml", "seed": "7", "tick_hz": "50"},
    "variation": {"robot.max_speed_mps": "0.3"},
    "session": {"child": "", "date": "2026-11-23T18:04:05Z"},
    "someone_else": {"k": "v"},
}


def test_records_decode_to_typed_fields_and_encode_back_as_read() -> None:
    meta = RecordingMetadata.from_records(RECORDS)
    assert meta.oimi == OimiRecord(format_version="9", recording_id="greeting-7", version="1.0")
    assert meta.scenario is not None and meta.scenario.seed_number == 7
    assert (meta.tick_hz, meta.params) == (50, "robot.max_speed_mps=0.3")
    assert meta.session == SessionRecord(child="", date="2026-11-23T18:04:05Z")
    assert meta.configuration is None and meta.live is None
    assert meta.records() == RECORDS
    assert list(meta.records()) == list(RECORDS)


def test_unset_keys_and_records_are_not_written() -> None:
    meta = RecordingMetadata(scenario=ScenarioRecord(name="x"))
    assert meta.records() == {"scenario": {"name": "x"}}


def test_a_value_that_does_not_read_is_none_not_an_error() -> None:
    meta = RecordingMetadata.from_records({"scenario": {"seed": "7x", "tick_hz": ""}})
    assert meta.scenario is not None and meta.scenario.seed_number is None
    assert meta.tick_hz is None


def test_a_known_record_that_is_not_a_string_table_is_a_recording_error() -> None:
    with pytest.raises(RecordingError, match=r"f.mcap: metadata: .*\$\.scenario\.seed"):
        RecordingMetadata.from_records({"scenario": {"seed": 7}}, source="f.mcap")  # type: ignore[dict-item]
