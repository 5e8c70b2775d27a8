"""A notebook session with the public API: check, run, compile, evaluate, analyse; silent."""

from __future__ import annotations

from pathlib import Path

import polars as pl
import pytest
from oimi.pipeline.messages import RobotStatus, Touch, WorldMap
from oimi.pipeline.think.errors import RuleSyntaxError
from oimi.scenarios.errors import ScenarioError

import oimi

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "bubbles"
PACKAGE = str(EXAMPLE / "bubbles")


def test_a_notebook_drives_the_public_api_end_to_end(tmp_path: Path, capsys) -> None:
    # 1. Check and load the scenario (its extension comes from the scenario file).
    assert oimi.check_scenario(EXAMPLE / "bubbles.toml") == []
    scenario = oimi.load_scenario(EXAMPLE / "bubbles.toml")
    assert scenario.scenario.name == "bubbles"

    # 2. Run it, recording, with a progress callback.
    seen: list[int] = []
    outcome = oimi.run(
        scenario, output=tmp_path / "s.mcap", progress=lambda done, total: seen.append(done)
    )
    assert outcome.ok and outcome.recording == tmp_path / "s.mcap"
    assert seen[-1] == outcome.summary.ticks == 1000

    # 3. Compile a script that needs the extension's functions.
    with pytest.raises(RuleSyntaxError, match="unknown function 'pops_at_least'"):
        oimi.compile_script(EXAMPLE / "bubbles" / "activities" / "bubble_song.txt")
    script = oimi.compile_script(
        EXAMPLE / "bubbles" / "activities" / "bubble_song.txt", extensions=[PACKAGE]
    )
    assert '"activityname": "bubble_song"' in oimi.script_json(script)

    # 4. Evaluate a condition against a map.
    world = WorldMap(
        robotstatus=RobotStatus(touch=[Touch(touchtype="C", duration=300, startingtime=900)])
    )
    touch = oimi.condition("! {E: bubble_touch (600)}", extensions=[PACKAGE])
    assert oimi.evaluate(touch, world, now_ms=1000).result is True
    assert oimi.evaluate(touch, world, now_ms=2000).result is False

    # 5. Open the recording as polars frames.
    frames = oimi.open_recording(outcome.recording)
    decisions = frames["/rules/decisions"]
    assert isinstance(decisions, pl.DataFrame)
    assert decisions.filter(pl.col("rule") == "pop_reward")["fired"].any()

    # Nothing printed along the way.
    assert capsys.readouterr() == ("", "")


def test_a_bad_scenario_is_a_located_error_not_a_print(tmp_path: Path, capsys) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\nextensions = ["no_such_extension_here"]\n')
    (problem,) = oimi.check_scenario(bad)
    assert isinstance(problem, ScenarioError)
    assert str(problem).startswith(f"{bad}:2:") and "no_such_extension_here" in str(problem)
    assert capsys.readouterr() == ("", "")
