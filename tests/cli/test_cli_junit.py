"""JUnit XML for a CI: a failure says how to run it again; a session's errors are shown even
when every expectation passed."""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree

from oimi.scenarios.session.expectations import Verdict
from oimi.scenarios.session.runner import RunResult, Summary

from oimi.console import write_junit

ERROR = "3.10 s rules: rule 'wave_back' (code 1100) raised KeyError: 'x' (functions.py:15); removed"


def result(*verdicts: Verdict, errors: tuple[str, ...] = ()) -> RunResult:
    summary = Summary(
        scenario="s", seed=1, ticks=10, duration_s=0.2, activities={}, goals_reached={},
        rules_fired={}, min_distance_m={}, max_speed_mps=0.0, contacts=0, rejected_inputs=0,
        errors=errors,
    )  # fmt: skip
    return RunResult(summary=summary, verdicts=verdicts)


FAILED = Verdict(name="greets", ok=False, detail="reached never")


def suites(folder: Path, a: Verdict, b: RunResult, **given: dict) -> ElementTree.Element:
    """The JUnit file of two runs, ``a-s1`` (one verdict) and ``b-s1``, written and read."""
    path = folder / "junit.xml"
    write_junit(path, [("a-s1", result(a)), ("b-s1", b)], **given)
    return ElementTree.parse(path).getroot()


def test_a_failure_ends_with_its_reproduction_and_errors_go_to_system_err(tmp_path: Path) -> None:
    passed = Verdict(name="waved", ok=True, detail="fired 4")
    a, b = suites(
        tmp_path,
        FAILED,
        result(passed, errors=(ERROR,)),
        reproduce={"a-s1": "oimi run a.toml --seed 1"},
    )
    assert a.find("testcase/failure").text == "reached never\nreproduce: oimi run a.toml --seed 1"
    assert a.find("system-err") is None
    assert b.find("testcase/failure") is None, "errors alone fail no expectation"
    assert b.find("system-err").text == f"ERROR at {ERROR}"


def test_a_run_that_crashed_is_an_error_with_its_traceback_not_a_failure(tmp_path: Path) -> None:
    crash = Verdict(name="run completed", ok=False, detail="ValueError: boom")
    trace = "Traceback (most recent call last):\nValueError: boom"
    a, b = suites(tmp_path, crash, result(FAILED), crashed={"a-s1": trace})
    assert (a.get("errors"), a.get("failures")) == ("1", "0")
    assert a.find("testcase/failure") is None
    error = a.find("testcase/error")
    assert error.get("message") == "ValueError: boom"
    assert error.text.startswith("Traceback (most recent call last):")
    assert (b.get("errors"), b.get("failures")) == ("0", "1")


def test_a_runs_seconds_are_its_suites_time_shared_by_its_cases(tmp_path: Path) -> None:
    """A CI shows durations from ``time``: the cases of a suite add up to the suite; a run
    finished by an earlier batch (no seconds) has no ``time`` rather than a made-up one."""
    passed = Verdict(name="waved", ok=True, detail="fired 4")
    a, b = suites(tmp_path, FAILED, result(passed, FAILED), seconds={"b-s1": 3.0})
    assert a.get("time") is None and a.find("testcase").get("time") is None
    assert b.get("time") == "3.000"
    assert [case.get("time") for case in b.iter("testcase")] == ["1.500", "1.500"]
