"""The loader checks each generator activity as Get Ready would: what the generator raises
(constructor included) or returns instead of a script is placed at its activity."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from oimi.pipeline.operator.generator import Catalogue
from oimi.pipeline.operator.generators import DanceGenerator
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import parse_scenario

TEXT = b'name = "x"\n[[activities]]\ngenerator = "dance"\noptions = { tempo = "slow" }\n'


def second_fails() -> Callable[[], DanceGenerator]:
    """A factory whose first instance (the catalogue's own) is made and the next one fails."""
    made: list[Dancer] = []

    def make() -> DanceGenerator:
        if made:
            raise ValueError("no dancer")
        made.append(Dancer())
        return made[0]

    return make


class Dancer(DanceGenerator):
    name = "dance"


class Lazy(Dancer):
    def generate(self):  # type: ignore[override]
        return None


@pytest.mark.parametrize(
    ("factory", "message"),
    [
        (second_fails, "create() raised ValueError: no dancer (test_scenario_generator_check.py:"),
        (lambda: Lazy, "generate() returned None, not a Script"),
    ],
    ids=["constructor", "none"],
)
def test_a_failing_generator_is_placed_at_its_activity(factory, message) -> None:
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(TEXT, source="s.toml", catalogue=Catalogue({"dance": factory()}))
    assert str(caught.value).startswith(
        f"s.toml:3:1: activities[0].generator: generator 'dance': {message}"
    ), str(caught.value)


def test_a_bad_option_is_still_placed_at_the_option() -> None:
    text = TEXT.replace(b'"slow"', b'"warp"')
    with pytest.raises(ScenarioError, match=r"^s\.toml:4:.*activities\[0\]\.options\.tempo"):
        parse_scenario(text, source="s.toml", catalogue=Catalogue({"dance": Dancer}))
