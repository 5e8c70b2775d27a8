"""Rebuilding a session from its recording: scripts named beside the scenario, and the notes
on what differs between the recording's set-up and this oimi's."""

from __future__ import annotations

from pathlib import Path

import msgspec
from oimi.replay.compare import format_report
from oimi.replay.redrive import redrive
from oimi.scenarios.session.activities import ACTIVITIES
from replay_tamper import SHORT, record, rewrite


def test_a_script_named_beside_the_scenario_redrives(tmp_path: Path) -> None:
    """``script = "mine.txt"`` resolves in the scenario's folder; the recording keeps the
    script by name only, and the rebuilt session must find it there too."""
    (tmp_path / "mine.txt").write_text(
        (ACTIVITIES / "test_act.txt").read_text().replace("[test_act]", "[mine]", 1)
    )
    scenario = tmp_path / "mine.toml"
    scenario.write_text(
        'name = "mine"\nseed = 3\nduration_s = 2.0\n[robot]\nx_m = 3.0\ny_m = 2.5\n'
        '[[activities]]\nscript = "mine.txt"\n'
    )
    comparison = redrive(record(scenario, tmp_path / "mine.mcap"))
    assert comparison.ok, format_report(comparison)


def test_the_notes_name_each_configuration_field_that_differs_or_is_new(tmp_path: Path) -> None:
    """A recording made before a field was added (or with another value) is noted field by
    field, not as two whole configurations."""

    def older(name: str, data: dict[str, str]) -> dict[str, str]:
        if name != "configuration":
            return data
        pipeline = msgspec.json.decode(data["pipeline"])
        del pipeline["safety"]["camera_range_m"]  # not in the recording: new since
        pipeline["register_capacity"] += 1  # another value (a register never fills here)
        return {**data, "pipeline": msgspec.json.encode(pipeline).decode()}

    new = record(SHORT, tmp_path / "new.mcap")
    rewrite(new, tmp_path / "old.mcap", metadata=older)
    comparison = redrive(tmp_path / "old.mcap")
    assert comparison.ok, format_report(comparison)
    assert comparison.notes == (
        "configuration.pipeline.register_capacity differs: recorded 17, now 16",
        "configuration.pipeline.safety.camera_range_m is new since the recording (now 5.0)",
    )
