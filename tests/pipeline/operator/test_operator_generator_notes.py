"""Generators as the thesis has them (3.2, 5.1): they see the map, keep state, hear rules,
and a rule can set one quiescent, which the button shows as Get Ready."""

from __future__ import annotations

from collections.abc import Mapping

from oimi.pipeline.messages import GeneratorNote, Human, Script, WorldMap
from oimi.pipeline.operator.commands import Add, Command, GetReady, Start
from oimi.pipeline.operator.generator import BaseGenerator, Catalogue, OptionValue
from oimi.pipeline.operator.generators.build import ScriptBuilder, led
from oimi.pipeline.operator.handler import GeneratorHandler, OperatorButton


class Looking(BaseGenerator):
    """Names its goal after the nearest child's distance, counting its scripts."""

    name = "looking"

    def build(self, values: Mapping[str, OptionValue]) -> Script:
        assert self.view is not None
        self.view.world_map.humans.clear()  # a copy: the loop's map must not change
        self.state["made"] = int(self.state.get("made", 0)) + 1  # type: ignore[arg-type]
        b = ScriptBuilder("looking")
        b.goal(f"seen_{len(self.heard)}_made_{self.state['made']}")
        b.instruction(leds=(led((0.0, 0.0, 1.0), duration_ms=100),))
        return b.build()


class Session:
    def __init__(self) -> None:
        self.generator = Looking()
        self.handler = GeneratorHandler(Catalogue({"looking": lambda: self.generator}))
        self.map = WorldMap(humans=[Human(id="c", creationtime=0, positionrho=1.2)])
        self.ids = 0

    def do(self, kind: type[Command], activity: str = "") -> str:
        self.ids += 1
        command = kind(id=self.ids, **({"activity": activity} if activity else {}))
        result = self.handler.handle(command, now_ms=self.ids * 20, world_map=self.map)
        assert result.reply.ok, result.reply.reason
        return result.reply.reason

    def get_ready(self) -> str:
        self.do(GetReady)
        self.handler.tick(0)
        script = self.handler.generated("looking")
        assert script is not None
        return script.goals[0].goalid


def note(*, quiesce: bool = False, text: str = "") -> GeneratorNote:
    return GeneratorNote(generator="looking", rule="r1", text=text, quiesce=quiesce)


def test_a_generator_sees_a_copy_of_the_map_at_generate_time() -> None:
    s = Session()
    s.do(Add, "looking")
    assert s.get_ready() == "seen_0_made_1"
    assert s.generator.view is not None and s.generator.view.now_ms == 40
    assert [h.id for h in s.map.humans] == ["c"], "the generator emptied only its copy"


def test_a_rule_note_is_heard_and_quiescence_shows_get_ready_then_regenerates() -> None:
    s = Session()
    s.do(Add, "looking")
    s.get_ready()
    assert s.handler.button is OperatorButton.START
    assert s.handler.deliver([note(text="popped 1")]) == [
        "rule 'r1' told generator 'looking': popped 1"
    ]
    assert s.handler.deliver([note(quiesce=True)]) == [
        "rule 'r1' set generator 'looking' quiescent"
    ]
    assert s.handler.button is OperatorButton.GET_READY
    assert s.get_ready() == "seen_1_made_2", "its state and what it heard survive"


def test_quiescence_while_running_waits_for_the_run_to_end() -> None:
    s = Session()
    s.do(Add, "looking")
    s.get_ready()
    s.do(Start)
    s.handler.deliver([note(quiesce=True)])
    assert s.handler.button is OperatorButton.STOP
    s.handler.activity_finished("looking", completed=True)
    assert s.handler.button is OperatorButton.GET_READY


def test_a_note_to_a_generator_not_selected_is_reported() -> None:
    s = Session()
    assert s.handler.deliver([note(text="hello")]) == [
        "rule 'r1': generator 'looking' is not selected"
    ]
