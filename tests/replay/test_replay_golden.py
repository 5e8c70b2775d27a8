"""Golden files: every library scenario against its projection, and what a change looks like."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from oimi.pipeline.events import RuleDecision, RuleDecisions, Topic
from oimi.pipeline.think import library
from oimi.replay import golden
from oimi.replay.golden import (
    Projection,
    check,
    digest_recording,
    project_scenario,
    regenerate,
    regenerate_command,
    stale_goldens,
)
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import Session, library_scenarios
from replay_tamper import SHORT


@pytest.mark.parametrize("scenario", library_scenarios(), ids=lambda path: path.stem)
def test_library_scenario_behaves_as_its_golden_file_says(scenario: Path) -> None:
    result = check(scenario)
    assert result.ok, result.problem


def test_every_golden_file_belongs_to_a_library_scenario() -> None:
    stale = stale_goldens(library_scenarios())
    assert not stale, f"golden files without a scenario: {stale}; run make golden"


def test_a_scenario_without_a_golden_file_says_how_to_write_that_one(tmp_path: Path) -> None:
    result = check(SHORT, tmp_path)
    assert not result.ok
    assert "no golden file" in result.problem
    assert f"run python -m oimi.replay.golden --regenerate {SHORT} --dir {tmp_path}" in (
        result.problem
    )


def test_a_library_scenarios_golden_is_regenerated_by_name_or_with_make_golden() -> None:
    greeting = next(s for s in library_scenarios() if s.stem == "greeting")
    assert regenerate_command(greeting) == (
        "python -m oimi.replay.golden --regenerate greeting  (every library scenario: make golden)"
    )


def test_a_one_line_rule_change_fails_with_a_diff_naming_the_rule(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    regenerate([SHORT], tmp_path)
    assert check(SHORT, tmp_path).ok
    text = library.ChildTooClose.condition_text
    closer = re.sub(r"OP< [0-9.]+", "OP< 0.05", text)  # the distance threshold, in metres
    assert closer != text
    monkeypatch.setattr(library.ChildTooClose, "condition_text", closer)
    result = check(SHORT, tmp_path)
    assert not result.ok
    assert f"--regenerate {SHORT} --dir {tmp_path}\n" in result.problem  # not make golden
    changed = [
        line
        for line in result.problem.splitlines()
        if line[:1] in "+-" and not line.startswith(("+++", "---"))
    ]
    assert any("decision child_too_close fired" in line for line in changed), result.problem


def test_the_golden_digest_is_the_digest_of_the_recorded_file(tmp_path: Path) -> None:
    session = Session(load_scenario(SHORT))
    with recorded(session, mcap=tmp_path / "s.mcap", rrd=None):
        session.run()
    digest_line = next(
        line for line in project_scenario(SHORT).splitlines() if line.startswith("digest ")
    )
    assert digest_line == f"digest {digest_recording(tmp_path / 's.mcap')}"


def test_golden_cli_checks_and_regenerates_on_purpose(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert golden.main(["--check", str(SHORT), "--dir", str(tmp_path)]) == 1
    assert "FAILED replay_short.toml" in capsys.readouterr().out
    assert golden.main(["--regenerate", str(SHORT), "--dir", str(tmp_path)]) == 0
    assert (tmp_path / "replay_short.golden.txt").is_file()
    assert golden.main(["--check", str(SHORT), "--dir", str(tmp_path)]) == 0
    assert "ok replay_short.toml" in capsys.readouterr().out


def test_golden_cli_takes_a_library_scenario_by_name(capsys: pytest.CaptureFixture[str]) -> None:
    assert golden.main(["--check", "blink"]) == 0
    assert capsys.readouterr().out == "ok blink.toml\n"
    assert golden.main(["--check", "blinks"]) == 2
    assert "blinks: no such file, nor a library scenario (one of " in capsys.readouterr().err


def _decisions(tick: int, *, fired: bool) -> RuleDecisions:
    decision = RuleDecision(rule="r1", rulecode=1, fired=fired, bindings={"?c": "Human/c"})
    return RuleDecisions(tick=tick, time_ms=tick * 20, decisions=(decision,))


def test_repeated_fired_decisions_at_consecutive_ticks_are_one_line_and_unfired_are_counted() -> (
    None
):
    projection = Projection()
    for tick, fired in ((1, True), (2, True), (3, True), (4, False), (5, True)):
        projection.record(Topic.RULE_DECISIONS, tick * 20_000_000, _decisions(tick, fired=fired))
    text = projection.text(header=["h"])
    body = text.split("---\n")[1].splitlines()
    assert body == [
        "00000.020 decision r1 fired ?c=Human/c  (x3 until 00000.060)",
        "00000.100 decision r1 fired ?c=Human/c",
    ]
    assert "decisions-not-fired 1\n" in text
    assert "messages /rules/decisions 5\n" in text
