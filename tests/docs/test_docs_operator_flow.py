"""What docs/live-sessions.md and docs/operator.md say about the operator holds."""

from __future__ import annotations

import re
from pathlib import Path

import msgspec
from oimi.pipeline.events import OperatorCommands, Topic, encode
from oimi.pipeline.loop import Pipeline, PipelineConfig
from oimi.pipeline.operator.commands import Add, Command, GetReady, Start
from oimi.pipeline.operator.generators import default_catalogue
from oimi.pipeline.operator.handler import GeneratorHandler
from oimi.pipeline.sink import MemorySink
from oimi.pipeline.think.rulecodes import RuleCode
from oimi.scenarios.session.activities import ACTIVITIES, ActivityLibrary

DOCS = Path(__file__).resolve().parents[2] / "docs"
IDLE = ActivityLibrary([ACTIVITIES]).idle()
"""The shipped idle activity."""


def replies(p: Pipeline, tick: int, *kinds: type[Command]) -> list[tuple[bool, str]]:
    sink = MemorySink()
    p.sink = sink
    commands = [
        kind(id=tick * 10 + i, **({"activity": "test_dance"} if kind is Add else {}))
        for i, kind in enumerate(kinds)
    ]
    p.tick(tick=tick, commands=commands)
    states = sink.on(Topic.OPERATOR_STATE)
    return [(r.ok, r.reason) for r in states[-1].replies] if states else []


def test_get_ready_and_start_in_one_tick_start_is_refused_then_accepted_next_tick() -> None:
    """Thesis 5.1: the Loading button "is an inert button displayed doing transition"; Start
    shows "When all Script Generators are ready and have generated their Script"."""
    text = (DOCS / "live-sessions.md").read_text(encoding="utf-8")
    assert "cannot start while the button shows loading" in text
    p = Pipeline(
        PipelineConfig(),
        idle=IDLE,
        resolve=lambda name: None,
        handler=GeneratorHandler(default_catalogue()),
        sink=MemorySink(),
    )
    replies(p, 0, Add)
    both = replies(p, 1, GetReady, Start)
    assert both[0][0] and both[1] == (False, "cannot start while the button shows loading")
    assert replies(p, 2, Start) == [(True, "started 1 activity")]


def test_operator_md_lists_every_rule_code() -> None:
    """Thesis 4.4: rulecode is "the corresponding code of the rule as defined in the World
    Model parser": every code the library defines is documented."""
    rows = re.findall(r"^\| (\d+) \| `(\w+)` \|", (DOCS / "operator.md").read_text(), flags=re.M)
    assert [(int(code), name) for code, name in rows] == [(c.value, c.name) for c in RuleCode]


def test_recording_md_shows_operator_commands_as_they_are_encoded() -> None:
    """Each recorded line that docs/recording.md shows decodes into ``OperatorCommands`` and
    encodes back to the same bytes (the union's tag first, only the verb's fields)."""
    text = (DOCS / "recording.md").read_text(encoding="utf-8")
    section = text.split("### Operator commands", 1)[1].split("```json\n", 1)[1]
    lines = section.split("```", 1)[0].splitlines()
    assert len(lines) == 3
    for line in lines:
        event = msgspec.json.decode(line, type=OperatorCommands)
        assert encode(event).decode() == line
    assert isinstance(msgspec.json.decode(lines[-1], type=OperatorCommands).commands[0], Start)
