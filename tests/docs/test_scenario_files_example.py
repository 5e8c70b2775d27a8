"""docs/scenario-files.md's complete example runs, and every one of its expectations passes."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.runner import Session

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "scenario-files.md"


def example() -> str:
    found = re.search(r"## A complete example\n.*?```toml\n(.*?)```", DOC.read_text(), flags=re.S)
    assert found, "the page has no complete example"
    return found.group(1)


def test_the_example_shows_every_event_kind_and_drives_the_session() -> None:
    scenario = tomllib.loads(example())
    kinds = {event["kind"] for event in scenario["events"]}
    assert kinds == {"operator", "joystick", "touch", "fault", "behaviour"}
    commands = [event["command"]["cmd"] for event in scenario["events"] if "command" in event]
    assert "get_ready" in commands and "start" in commands
    assert commands.index("get_ready") < commands.index("start")


def test_the_complete_example_passes_every_expectation(tmp_path: Path) -> None:
    text = example()
    # Its scripts are found in scenarios/library/, as for any scenario outside the library.
    path = tmp_path / "ball_game.toml"
    path.write_text(text)
    result = Session(load_scenario(path)).run()
    assert len(result.verdicts) == len(tomllib.loads(text)["expect"])
    assert [f"{v.name}: {v.detail}" for v in result.verdicts if not v.ok] == []
