"""The operator's commands: one tagged union, its JSON, and a handler that knows every member."""

from __future__ import annotations

from typing import get_args

import msgspec
import pytest
from oimi.pipeline.operator.commands import (
    VERBS,
    Add,
    OperatorCommand,
    Remove,
    Reorder,
    Start,
    describe,
)
from oimi.pipeline.operator.generators import default_catalogue
from oimi.pipeline.operator.handler import GeneratorHandler

EXAMPLES: list[OperatorCommand] = [
    Add(id=1, activity="test_dance", options={"tempo": "fast"}),
    Remove(id=2, activity="test_dance"),
    Reorder(id=3, activity="test_dance", position=0),
    Start(id=4),
]


@pytest.mark.parametrize("command", EXAMPLES, ids=lambda c: c.verb)
def test_a_command_encodes_with_its_tag_first_and_decodes_back(command: OperatorCommand) -> None:
    data = msgspec.json.encode(command)
    assert data.startswith(b'{"cmd":"' + command.verb.encode() + b'","id":')
    assert msgspec.json.decode(data, type=OperatorCommand) == command


def test_only_the_verbs_own_fields_are_accepted() -> None:
    with pytest.raises(msgspec.ValidationError, match="unknown field `activity`"):
        msgspec.json.decode(b'{"cmd": "start", "activity": "x"}', type=OperatorCommand)
    with pytest.raises(msgspec.ValidationError, match=r"Expected `int` >= 0 - at `\$.position`"):
        msgspec.json.decode(
            b'{"cmd": "reorder", "activity": "x", "position": -1}', type=OperatorCommand
        )
    with pytest.raises(msgspec.ValidationError, match="missing required field `activity`"):
        msgspec.json.decode(b'{"cmd": "remove"}', type=OperatorCommand)


def test_verbs_are_the_members_tags_in_order() -> None:
    assert VERBS == (
        "list",
        "add",
        "remove",
        "reorder",
        "get_ready",
        "start",
        "stop",
        "restart",
        "clear",
    )


def test_describe_gives_the_verb_and_its_fields() -> None:
    assert [describe(c) for c in EXAMPLES] == [
        "add test_dance tempo=fast",
        "remove test_dance",
        "reorder test_dance position=0",
        "start",
    ]


@pytest.mark.parametrize("kind", get_args(OperatorCommand), ids=lambda k: k.__name__)
def test_the_handler_answers_every_member_of_the_union(kind: type) -> None:
    fields = {"activity": "test_dance"} if "activity" in kind.__struct_fields__ else {}
    if "position" in kind.__struct_fields__:
        fields["position"] = 0
    result = GeneratorHandler(default_catalogue()).handle(kind(id=7, **fields), now_ms=0)
    assert result.reply.id == 7 and result.reply.reason
