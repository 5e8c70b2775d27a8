"""`oimi run` with an extension's rule that raises: the session goes on, the error is in the
summary and on ``/log``, the chain shows the rule removed, and the recording redrives."""

from __future__ import annotations

from pathlib import Path

import msgspec
from cli_process import oimi
from oimi.pipeline.events import Level, LogEntries, RuleChainState, Topic
from oimi.recorder.reader import open_recording

EXTENSION = """
from oimi.pipeline.think.rules import Effect, Rule

NAME = "breaks"


class Breaks(Rule):
    rulecode = 1010
    condition_text = '! {E: touched ("C")}'

    def act(self, world_map, found, ctx):
        raise RuntimeError("act boom")


def register(ext):
    ext.rule(Breaks)
"""

SCRIPT = """[breaks_script]
[alfa:1010, breaks, "", "", A, U]
[goal:g]
[action]
[b#one#blk_inst: MV() LD("0.3, 0.7, 1, 1, 0, 3000") AO()]
[b#end#blk_terminus]
"""

SCENARIO = """name = "breaks"
seed = 1
duration_s = 4.0
tick_hz = 50
extensions = ["breaks.py"]
[robot]
x_m = 3.0
y_m = 2.5
theta_rad = 0.0
[[humans]]
id = "child"
x_m = 3.8
y_m = 2.5
[[activities]]
script = "breaks.txt"
[[events]]
at_s = 1.0
kind = "touch"
human = "child"
touchtype = "C"
duration_ms = 300
"""


def test_a_rule_that_raises_is_removed_reported_and_the_session_runs_on(tmp_path: Path) -> None:
    (tmp_path / "breaks.py").write_text(EXTENSION)
    (tmp_path / "breaks.txt").write_text(SCRIPT)
    scenario = tmp_path / "breaks.toml"
    scenario.write_text(SCENARIO)
    out = tmp_path / "breaks.mcap"
    done = oimi("run", "-q", scenario, "-o", out, "--json")
    assert done.returncode == 0, done.stdout + done.stderr
    line = 1 + EXTENSION.splitlines().index('        raise RuntimeError("act boom")')
    report = f"rule 'breaks' (code 1010) raised RuntimeError: act boom (breaks.py:{line}); removed"
    summary = msgspec.json.decode(done.stdout)["summary"]
    assert summary["errors"] == [f"1.00 s rules: {report}"]
    assert summary["activities"] == {"breaks_script": "completed"}, "the script ran on"

    recording = open_recording(out)
    errors = [
        entry
        for m in recording.iter_messages([Topic.LOG])
        for entry in m.decoded().entries  # type: ignore[union-attr]
        if isinstance(m.decoded(), LogEntries) and entry.level == Level.ERROR
    ]
    assert [(e.source, e.message, e.ref) for e in errors] == [("rules", report, "breaks")]
    chains = [m.decoded() for m in recording.iter_messages([Topic.RULE_CHAIN])]
    removed = [c for c in chains if isinstance(c, RuleChainState) and "breaks" in c.removed]
    assert removed and removed[0].time_ms == 1000 and removed[0].applied == ()

    again = oimi("replay", out, "--mode", "redrive")
    assert again.returncode == 0, again.stdout + again.stderr


def test_the_human_summary_lists_the_error(tmp_path: Path) -> None:
    (tmp_path / "breaks.py").write_text(EXTENSION)
    (tmp_path / "breaks.txt").write_text(SCRIPT)
    (tmp_path / "breaks.toml").write_text(SCENARIO)
    done = oimi("run", "-q", tmp_path / "breaks.toml", "--no-record")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "  ERROR at 1.00 s rules: rule 'breaks' (code 1010) raised RuntimeError" in done.stdout
