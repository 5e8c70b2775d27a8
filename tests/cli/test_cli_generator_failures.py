"""An extension's generator that raises or returns no script: `oimi check` and `oimi run` say
so at the activity's line (exit 2); one that fails only on the live map has get_ready refused,
on /log, and the run goes on (exit 0)."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_process import oimi
from oimi.pipeline.events import Level

from oimi import open_recording

GENERATOR = """\
from oimi.pipeline.operator.generator import BaseGenerator
from oimi.pipeline.operator.generators.build import ScriptBuilder, led

NAME = "{name}"


class Faulty(BaseGenerator):
    name = "{name}"

    def build(self, values):
        {body}
        b = ScriptBuilder(self.name)
        b.goal("g")
        b.instruction(leds=(led((1.0, 1.0, 1.0), duration_ms=500),))
        return b.build()


def register(ext):
    ext.generator(Faulty)
"""

SCENARIO = """\
name = "faulty"
seed = 1
duration_s = 2.0
tick_hz = 50
extensions = ["{name}.py"]

[[activities]]
generator = "{name}"
"""


def scenario(folder: Path, name: str, body: str) -> Path:
    """A scenario whose one activity is generator ``name`` (in ``name.py``), whose build
    starts with ``body`` (line 11 of the file)."""
    (folder / f"{name}.py").write_text(GENERATOR.format(name=name, body=body))
    path = folder / f"{name}.toml"
    path.write_text(SCENARIO.format(name=name))
    return path


FAILURES = [
    (
        "raiser",
        'raise RuntimeError("kaboom")',
        "generate() raised RuntimeError: kaboom (raiser.py:11)",
    ),
    ("nothing", "return None", "generate() returned None, not a Script"),
]


@pytest.mark.parametrize(("name", "body", "what"), FAILURES, ids=[f[0] for f in FAILURES])
@pytest.mark.parametrize("verb", ["check", "run"])
def test_a_failing_generator_is_a_located_error(tmp_path: Path, verb, name, body, what) -> None:
    path = scenario(tmp_path, name, body)
    done = oimi(verb, path, *(["-o", tmp_path / "x.mcap"] if verb == "run" else []))
    assert done.returncode == 2, done.stdout + done.stderr
    assert f"{path}:8:1: activities[0].generator: generator {name!r}: {what}" in (
        done.stdout + done.stderr
    )
    assert "Traceback" not in done.stderr
    assert not (tmp_path / "x.mcap").exists()


def test_a_generator_failing_on_the_live_map_has_get_ready_refused(tmp_path: Path) -> None:
    path = scenario(tmp_path, "late", 'if self.view is not None:\n            raise KeyError("x")')
    assert oimi("check", path).returncode == 0, "without a map it generates"
    out = tmp_path / "late.mcap"
    done = oimi("run", "-q", path, "-o", out)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "Traceback" not in done.stderr
    frames = open_recording(out)
    log = frames["/log"].filter(frames["/log"]["source"] == "operator")["message"].to_list()
    assert "generator 'late': generate() raised KeyError: 'x' (late.py:12)" in log
    errors = frames["/log"].filter(frames["/log"]["level"] == Level.ERROR)
    assert errors.select("source", "message", "ref").rows() == [
        ("generators", "generator 'late': generate() raised KeyError: 'x' (late.py:12)", "late")
    ], "a bug in the generator is an error, beside the refused command"
    assert "generators: generator 'late': generate() raised" in done.stdout
    assert frames["/operator/state"]["button"].to_list()[-1] == "get_ready"
