"""Fuzzing scenario files (issue 15): mutated library scenarios through ``oimi check`` and a
short run. Whatever the mutation, ``check`` exits 0 or 2 with a located message, and a
scenario it passes runs without an exception, a hang or a signal, ending 0 or 1.

Bounded for ``make test``; ``make fuzz`` runs ``OIMI_FUZZ_EXAMPLES`` times as many examples.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import msgspec
import pytest
from hypothesis import HealthCheck, given
from hypothesis import strategies as st
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import LIBRARY_DIR, apply_overrides, load_scenario
from oimi.scenarios.profile import THESIS_ROBOT
from oimi.scenarios.session.runner import Session

from oimi.cli import main

from .fuzzing import fuzz_settings, no_hang

RUN_S = 0.5
"""Simulated seconds of each short run."""

LIBRARY = {path.name: path.read_text() for path in sorted(LIBRARY_DIR.glob("*.toml"))}
NUMBER = re.compile(r"(?<=[=\[,{ ])-?\d+(?:\.\d+)?(?:e[+-]?\d+)?(?=[\s,\]}])")
STRING = re.compile(r'"[^"\n]*"')
ASSIGNMENT = re.compile(r"^[ \t]*[A-Za-z_][\w.\"]*[ \t]*=[^\n]*\n", re.M)

NUMBERS = ["nan", "inf", "-inf", "-1", "0", "0.0", "-0.5", "1e300", "-1e300", "1e308", "1e-300",
           "9223372036854775808", "2.0", "3", "1000"]  # fmt: skip
STRINGS = ['""', '"../../x.txt"', '"/etc/passwd"', '"nope"', '"activities/none.txt"', '"nan"',
           '"stand"', '"child"', '"camera"', '"offline"', '"silent"', '"add"', '"a/b"',
           '"test_dance"', '"greeting"', '"activities/playroom.txt"', "1.5", "[]",
           "{}"]  # fmt: skip
LOCATED = re.compile(r"^(?P<file>.+?\.toml)(?::\d+:\d+)?: \S")


@st.composite
def mutated(draw: st.DrawFn) -> tuple[str, str]:
    """A library scenario's name and its text after one to three mutations."""
    name = draw(st.sampled_from(sorted(LIBRARY)))
    text = LIBRARY[name]
    for _ in range(draw(st.integers(1, 3))):
        text = draw(st.sampled_from(MUTATIONS))(draw, text)
    return name, text


def _pick(draw: st.DrawFn, matches: list[re.Match[str]]) -> re.Match[str] | None:
    return draw(st.sampled_from(matches)) if matches else None


def _replace(text: str, match: re.Match[str] | None, new: str) -> str:
    return text if match is None else text[: match.start()] + new + text[match.end() :]


def _number(draw: st.DrawFn, text: str) -> str:
    """A number replaced with NaN, an infinity, a negative, zero, a huge or a tiny value."""
    return _replace(text, _pick(draw, list(NUMBER.finditer(text))), draw(st.sampled_from(NUMBERS)))


def _string(draw: st.DrawFn, text: str) -> str:
    """A string swapped for another (paths, names, codes) or a value of another type."""
    return _replace(text, _pick(draw, list(STRING.finditer(text))), draw(st.sampled_from(STRINGS)))


def _delete(draw: st.DrawFn, text: str) -> str:
    """A field deleted (a required one, too)."""
    return _replace(text, _pick(draw, list(ASSIGNMENT.finditer(text))), "")


def _nest(draw: st.DrawFn, text: str) -> str:
    """A value wrapped in inline arrays, sometimes thousands deep."""
    match = _pick(draw, list(NUMBER.finditer(text)) + list(STRING.finditer(text)))
    depth = draw(st.sampled_from([1, 1, 2, 3, 5000]))
    return _replace(text, match, "[" * depth + (match.group() if match else "") + "]" * depth)


def _duplicate(draw: st.DrawFn, text: str) -> str:
    """A field given twice (or a line repeated)."""
    match = _pick(draw, list(ASSIGNMENT.finditer(text)))
    return _replace(text, match, match.group() * 2 if match else "")


MUTATIONS = [_number] * 6 + [_string] * 3 + [_delete] * 2 + [_nest, _duplicate]
"""Mostly values (they reach the session), sometimes the file's structure."""


def check_then_run(path: Path, capsys: pytest.CaptureFixture[str]) -> int:
    """``oimi check`` in process; when it passes, a short run of the scenario. The exit code."""
    code = main(["check", str(path)])
    out, err = capsys.readouterr()
    if code == 2:
        first = err.splitlines()[0]
        match = LOCATED.match(first)
        assert match and match.group("file") == str(path), f"not located: {first!r}"
        return 2
    assert code == 0 and out == f"{path}: ok\n", (code, out, err)
    loaded = load_scenario(path)
    short = msgspec.structs.replace(
        loaded.scenario, duration_s=min(loaded.scenario.duration_s, RUN_S)
    )
    result = Session(msgspec.structs.replace(loaded, scenario=short)).run()
    for verdict in result.verdicts:  # a pass never rests on a NaN or an infinity
        assert not (verdict.ok and re.search(r"\b(nan|inf)\b", verdict.detail)), verdict
    return 0 if result.ok else 1


@fuzz_settings(60, suppress=[HealthCheck.function_scoped_fixture])
@given(case=mutated())
def test_mutated_library_scenarios_are_checked_or_run_never_crash(tmp_path, capsys, case):
    name, text = case
    path = tmp_path / name
    path.write_text(text)
    with no_hang(f"oimi check {name}, then a short run"):
        assert check_then_run(path, capsys) in (0, 1, 2)


# ----------------------------------------------------------------- overrides


def numeric_keys(node: object, prefix: str = "") -> list[str]:
    """Every dotted ``--param`` key of a number in a decoded scenario."""
    if isinstance(node, dict):
        return [k for key, v in node.items() for k in numeric_keys(v, f"{prefix}{key}.")]
    if isinstance(node, list):
        return [k for i, v in enumerate(node) for k in numeric_keys(v, f"{prefix}{i}.")]
    is_number = isinstance(node, int | float) and not isinstance(node, bool)
    return [prefix.rstrip(".")] if is_number else []


GREETING = load_scenario(LIBRARY_DIR / "greeting.toml")
KEYS = numeric_keys(msgspec.to_builtins(GREETING.scenario))


@fuzz_settings(60)
@given(
    overrides=st.dictionaries(
        st.sampled_from(KEYS), st.sampled_from(NUMBERS), min_size=1, max_size=3
    )
)
def test_params_are_refused_with_their_field_or_run(overrides):
    """``--param`` values go through the same validation: refused naming the field, or run."""
    with no_hang(f"the overrides {overrides}"):
        try:
            scenario = apply_overrides(GREETING.scenario, overrides)
        except ScenarioError as error:
            assert re.match(r"<overrides>: override: (\S+ \(.+?\): |\S+: )", str(error)), error
            return
        short = msgspec.structs.replace(scenario, duration_s=min(scenario.duration_s, RUN_S))
        Session(msgspec.structs.replace(GREETING, scenario=short)).run()
        robot = scenario.robot
        assert robot.max_speed_mps <= THESIS_ROBOT.max_speed_mps


# ----------------------------------------------------------- as a real process

PROCESS_CASES = [
    ("greeting.toml", "[sensors]\nstatus_period_s = 0\n", 2),
    ("child_too_close.toml", "[robot]\nmass_kg = inf\n", 2),
    ("blink.toml", "", 0),  # unmutated: a whole run, to show the process ends cleanly
]


def _with_section(text: str, section: str) -> str:
    """``text`` with ``section`` (``[table]\\nkey = value``) merged into its table."""
    if not section:
        return text
    header = section.splitlines()[0]
    if header in text:
        return text.replace(header + "\n", section + "\n", 1)
    return text + "\n" + section


@pytest.mark.parametrize(("name", "section", "expected"), PROCESS_CASES)
def test_oimi_run_as_a_process_ends_with_a_code_never_a_signal(tmp_path, name, section, expected):
    path = tmp_path / name
    path.write_text(_with_section(LIBRARY[name], section))
    done = subprocess.run(
        [sys.executable, "-m", "oimi", "run", str(path), "--no-record", "-q"],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=120,  # a guard against the old infinite loops, not a timing
        check=False,
    )
    assert done.returncode == expected, done.stderr
    assert "Traceback" not in done.stderr
    if expected == 2:
        assert done.stderr.startswith(f"{path}:"), done.stderr
