"""Rebuilding a session from its recording: scripts named beside the scenario."""

from __future__ import annotations

from pathlib import Path

from oimi.replay.compare import format_report
from oimi.replay.redrive import redrive
from oimi.scenarios.session.activities import ACTIVITIES
from replay_tamper import record


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
