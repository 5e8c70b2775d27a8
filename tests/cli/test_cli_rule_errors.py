"""`oimi run` with an extension's rule that raises (acting, or being created): the session goes
on, the error is in the summary and on ``/log``, the chain shows the rule removed, and the
recording redrives."""

from __future__ import annotations

from pathlib import Path

import msgspec
from cli_process import oimi
from oimi.pipeline.events import Level, LogEntries, RuleChainState, Topic
from oimi.recorder.reader import open_recording
from user_rule import extension, rule_scenario

BODY = '        raise RuntimeError("act boom")'


def test_a_rule_that_raises_is_removed_reported_and_the_session_runs_on(tmp_path: Path) -> None:
    scenario = rule_scenario(tmp_path, "breaks", BODY)
    out = tmp_path / "breaks.mcap"
    done = oimi("run", "-q", scenario, "-o", out, "--json")
    assert done.returncode == 0, done.stdout + done.stderr
    line = 1 + extension("breaks", BODY).splitlines().index(BODY)
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
    done = oimi("run", "-q", rule_scenario(tmp_path, "breaks", BODY), "--no-record")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "  ERROR at 1.00 s rules: rule 'breaks' (code 1010) raised RuntimeError" in done.stdout


def test_a_rule_class_that_cannot_be_created_is_an_error_not_the_end(tmp_path: Path) -> None:
    scenario = rule_scenario(tmp_path, "unmade", "        return None")
    source = tmp_path / "unmade.py"
    act = "    def act(self, world_map, found, ctx):"
    init = "    def __init__(self, *args, **kwargs):\n        raise RuntimeError('no')\n\n"
    source.write_text(source.read_text().replace(act, init + act))
    line = 1 + source.read_text().splitlines().index("        raise RuntimeError('no')")
    out = tmp_path / "unmade.mcap"
    done = oimi("run", "-q", scenario, "-o", out, "--json")
    assert done.returncode == 0, done.stdout + done.stderr
    report = f"rule 'unmade' (code 1010) could not be created: RuntimeError: no (unmade.py:{line})"
    summary = msgspec.json.decode(done.stdout)["summary"]
    assert summary["errors"] == [f"0.02 s rules: {report}"], "when the script loads it"
    assert summary["activities"] == {"unmade_script": "completed"}, "the script ran on"
    again = oimi("replay", out, "--mode", "redrive")
    assert again.returncode == 0, again.stdout + again.stderr
