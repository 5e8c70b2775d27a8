"""A user's code in a loop that does not end no longer hangs oimi: the watchdog stops it, the
pipeline's guards remove the rule (or refuse the generator), the session goes on, and the
recording replays identically, live or not."""

from __future__ import annotations

from pathlib import Path

import msgspec
from cli_process import oimi
from oimi.pipeline.events import Level, LogEntries, Topic
from oimi.recorder.reader import open_recording
from user_rule import extension, rule_scenario

BODY = """\
        n = 0
        while True:
            try:
                n += 1
            except Exception:
                pass"""
DEF = "    def act(self, world_map, found, ctx):"
DEF_LINE = 1 + extension("endless", BODY).splitlines().index(DEF)
REPORT = (
    "rule 'endless' (code 1010) raised Overrun: did not return in time"
    f" (in Endless.act, endless.py:{DEF_LINE}); removed"
)


def scenario(folder: Path) -> Path:
    return rule_scenario(folder, "endless", BODY)


def errors(path: Path) -> list[tuple[int, str, str]]:
    return [
        (m.tick, entry.source, entry.message)
        for m in open_recording(path).iter_messages([Topic.LOG])
        if isinstance(log := m.decoded(), LogEntries)
        for entry in log.entries
        if entry.level == Level.ERROR
    ]


def test_an_endless_rule_is_stopped_removed_and_the_run_goes_on(tmp_path: Path) -> None:
    out = tmp_path / "endless.mcap"
    done = oimi("run", "-q", scenario(tmp_path), "-o", out, "--json", timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr
    summary = msgspec.json.decode(done.stdout)["summary"]
    assert summary["errors"] == [f"1.00 s rules: {REPORT}"]
    assert summary["activities"] == {"endless_script": "completed"}, "the script ran on"
    assert errors(out) == [(50, "rules", REPORT)]
    for mode in ("redrive", "rerun"):  # stopped again, alike, at the same tick
        again = oimi("replay", out, "--mode", mode, timeout=60)
        assert again.returncode == 0, again.stdout + again.stderr
        assert "identical" in again.stdout


def test_a_live_session_survives_an_endless_rule(tmp_path: Path) -> None:
    out = tmp_path / "live.mcap"
    done = oimi(
        "serve", scenario(tmp_path), "--no-tcp", "--no-console", "--duration-s", "2.0", "-o", out,
        timeout=60,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert errors(out) == [(50, "rules", REPORT)]
    assert open_recording(out).meta.session.ticks == "100", "every tick was run"
    again = oimi("replay", out, "--mode", "redrive", timeout=60)
    assert again.returncode == 0, again.stdout + again.stderr


GENERATOR = """\
from oimi.pipeline.operator.generator import BaseGenerator

NAME = "stuck"


class Stuck(BaseGenerator):
    name = "stuck"

    def build(self, values):
        while True:
            pass


def register(ext):
    ext.generator(Stuck)
"""


def test_an_endless_generator_is_a_located_error_of_the_check(tmp_path: Path) -> None:
    (tmp_path / "stuck.py").write_text(GENERATOR)
    path = tmp_path / "stuck.toml"
    path.write_text(
        'name = "stuck"\nseed = 1\nduration_s = 1.0\nextensions = ["stuck.py"]\n'
        '[[activities]]\ngenerator = "stuck"\n'
    )
    done = oimi("check", path, timeout=60)
    assert done.returncode == 2, done.stdout + done.stderr
    assert (
        f"{path}:6:1: activities[0].generator: generator 'stuck': generate() raised"
        " Overrun: did not return in time (in Stuck.build, stuck.py:9)"
    ) in done.stdout + done.stderr
