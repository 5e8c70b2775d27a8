from __future__ import annotations

import itertools
from datetime import timedelta
from pathlib import Path

import msgspec
import polars as pl
import pytest
from oimi.analysis.load import (
    TIME,
    AnalysisWarning,
    load_session,
    payloads_to_tables,
    polars_dtype,
    read_payloads,
    struct_schema,
)
from oimi.pipeline.events import (
    ActuatorCommands,
    OperatorCommands,
    RuleDecision,
    RuleDecisions,
    Topic,
    encode,
)
from oimi.pipeline.messages import AudioCommand, LedCommand, MoveCommand, Source
from oimi.pipeline.operator.commands import Reorder, Start
from oimi.recorder.errors import RecordingError
from oimi.recorder.reader import open_recording
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import Session

LIBRARY = Path(__file__).resolve().parents[2] / "scenarios" / "library"


def test_schema_follows_the_struct_and_leaves_out_free_keyed_dicts() -> None:
    schema = struct_schema(RuleDecision)
    assert schema["rule"] == pl.String
    assert schema["fired"] == pl.Boolean
    assert schema["changes"] == pl.List(
        pl.Struct({"path": pl.String, "old": pl.String, "new": pl.String})
    )
    assert "bindings" not in schema


def test_optional_fixed_tuple_becomes_a_nullable_list() -> None:
    info = msgspec.inspect.type_info(MoveCommand)
    requested = next(f for f in info.fields if f.name == "requested")
    assert polars_dtype(requested.type) == pl.List(pl.Float64)


def test_operator_commands_are_one_row_each_with_the_tag_and_nulls_for_absent_fields() -> None:
    payload = encode(
        OperatorCommands(
            tick=3,
            time_ms=60,
            commands=(Reorder(id=1, activity="a", position=2), Start(id=2)),
        )
    )
    table = payloads_to_tables(Topic.OPERATOR_COMMANDS, [payload])["/operator/commands"]
    assert table.select("id", "cmd", "activity", "position").rows() == [
        (1, "reorder", "a", 2),
        (2, "start", None, None),
    ]


def test_actuator_commands_are_one_row_each_with_the_channel_and_its_own_fields() -> None:
    payload = encode(
        ActuatorCommands(
            tick=2,
            time_ms=40,
            commands=(
                MoveCommand(source=Source.SCRIPT, v_x=0.4, clamped=True, requested=(9.0, 0, 0)),
                LedCommand(source=Source.SCRIPT, r=1.0),
                AudioCommand(source=Source.SCRIPT, track_path="a.wav", stop=True),
            ),
        )
    )
    table = payloads_to_tables(Topic.ACTUATOR_COMMANDS, [payload])["/actuator/commands"]
    assert table.columns[3:6] == ["channel", "source", "stop"]
    assert table.select("channel", "stop", "v_x", "r", "track_path", "clamped").rows() == [
        ("move", False, 0.4, None, None, True),
        ("led", False, None, 1.0, None, False),
        ("audio", True, None, None, "a.wav", None),
    ]
    assert table["requested"].to_list() == [[9.0, 0.0, 0.0], None, None]


def test_decisions_are_exploded_one_row_per_rule() -> None:
    payloads = [
        encode(
            RuleDecisions(
                tick=t,
                time_ms=20 * t,
                decisions=(
                    RuleDecision(rule="a", rulecode=1, fired=t == 1, bindings={"?c": "Human/x"}),
                    RuleDecision(rule="b", rulecode=2, fired=False),
                ),
            )
        )
        for t in range(3)
    ]
    table = payloads_to_tables(Topic.RULE_DECISIONS, payloads)["/rules/decisions"]
    assert table.height == 6
    assert table.filter("fired")[["tick", "rule"]].rows() == [(1, "a")]
    assert table.schema[TIME] == pl.Duration("ms")
    assert table[TIME][3] == timedelta(milliseconds=20)


def test_no_payloads_give_empty_tables_with_the_columns() -> None:
    frame = read_payloads(Topic.LOG, [])
    assert frame.height == 0
    assert {"tick", "time_ms", "entries"} <= set(frame.columns)


def test_every_message_of_the_loaded_topics_is_read(walk_mcap: Path) -> None:
    data = load_session(walk_mcap)
    summary = open_recording(walk_mcap).summary
    assert data.recovery is None
    # 500 ticks: the world's state every second tick (no contact here) and at the last
    assert data["/world/state"].height == summary["/world/state"] == 251
    assert data["/world/state"]["tick"].to_list() == [*range(0, 500, 2), 499]
    assert data["/world/state/humans"]["id"].unique().to_list() == ["child"]
    assert data["/rules/decisions"]["tick"].n_unique() == summary["/rules/decisions"]
    assert "/map" not in data.tables
    assert data.session_id == "walk at robot-seed0"


def test_the_map_asked_for_is_the_full_map_after_each_map_message(walk_mcap: Path) -> None:
    maps = list(open_recording(walk_mcap).maps())
    frame = load_session(walk_mcap, topics=["/map"])["/map"]
    assert frame["tick"].to_list() == [m.tick for m in maps]
    assert frame["lastupdatetime"].to_list() == [m.map.lastupdatetime for m in maps]
    rhos = frame["humans"].list.eval(pl.element().struct.field("positionrho")).to_list()
    assert rhos == [[h.positionrho for h in m.map.humans] for m in maps]
    assert all(rhos), "every row holds every human, not only the ones a delta changed"


def test_a_truncated_recording_is_loaded_up_to_the_damage_with_a_warning(tmp_path: Path) -> None:
    session = Session(load_scenario(LIBRARY / "child_too_close.toml"))
    whole_file = tmp_path / "whole.mcap"
    with recorded(session, mcap=whole_file, rrd=None, chunk_size_bytes=64 * 1024):
        session.run()  # in chunks of 64 KiB: the cut below falls after some of them
    whole = whole_file.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[: len(whole) * 6 // 10])
    with pytest.warns(
        AnalysisWarning,
        match=r"cut\.mcap: damaged at byte \d+ .*recovered: \d+ messages before it; analysed in",
    ):
        data = load_session(cut)
    assert data.recovery is not None
    assert 0 < data["/world/state"].height < 500
    ticks = data["/world/state"]["tick"].to_list()
    assert ticks[0] == 0 and all(0 < b - a <= 2 for a, b in itertools.pairwise(ticks))


def test_a_file_that_is_not_a_recording_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "notes.mcap"
    bad.write_text("these are notes, not a recording")
    with pytest.raises(RecordingError, match="not an MCAP file"):
        load_session(bad)


def test_a_table_not_loaded_is_refused_naming_the_loaded_ones_and_how_to_load_it(
    walk_mcap: Path,
) -> None:
    data = load_session(walk_mcap)
    assert "/log" in data and "/map" not in data and list(data) == sorted(data.tables)
    with pytest.raises(KeyError, match=r"topic '/map' was not loaded: ask for it .*topics=.*/log"):
        data["/map"]
    with pytest.raises(KeyError, match=r"no table '/logs'; loaded: .*/log, "):
        data["/logs"]
