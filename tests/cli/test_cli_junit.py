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


def test_a_failure_ends_with_its_reproduction_and_errors_go_to_system_err(tmp_path: Path) -> None:
    path = tmp_path / "junit.xml"
    failed = Verdict(name="greets", ok=False, detail="reached never")
    passed = Verdict(name="waved", ok=True, detail="fired 4")
    write_junit(
        path,
        [("a-s1", result(failed)), ("b-s1", result(passed, errors=(ERROR,)))],
        reproduce={"a-s1": "oimi run a.toml --seed 1"},
    )
    a, b = ElementTree.parse(path).getroot()
    assert a.find("testcase/failure").text == "reached never\nreproduce: oimi run a.toml --seed 1"
    assert a.find("system-err") is None
    assert b.find("testcase/failure") is None, "errors alone fail no expectation"
    assert b.find("system-err").text == f"ERROR at {ERROR}"
