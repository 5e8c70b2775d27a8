"""The operator's commands (thesis 5.1): one tagged union, the same object everywhere.

A command is one JSON object tagged by ``cmd``, with the fields of its verb only::

    {"id": 1, "cmd": "add", "activity": "test_dance", "options": {"tempo": "fast"}}
    {"id": 2, "cmd": "get_ready"}

The App Interface decodes it from a client's line, a scenario's ``operator`` event
holds it as its ``command``, ``/operator/commands`` records it, and the Generator
Handler ``match``es on its class. A session numbers the commands it applies
(``id``); a client's reply echoes the client's own.
"""

from __future__ import annotations

from typing import Annotated, Final, get_args

import msgspec
from oimi.pipeline.messages import Message


class Command(Message, tag_field="cmd"):
    """Base of every operator command."""

    id: int = 0
    """The request's id, echoed in its reply."""

    @property
    def verb(self) -> str:
        """The command's tag (``add``, ``start`` ...)."""
        return self.__struct_config__.tag  # type: ignore[return-value]


class ListActivities(Command, tag="list", kw_only=True):
    """The available activities with their options (the App Interface's reply carries them)."""


class Add(Command, tag="add", kw_only=True):
    """Select the generator ``activity`` with its ``options`` (Plus Button)."""

    activity: str
    options: dict[str, str] = {}


class Remove(Command, tag="remove", kw_only=True):
    """Deselect ``activity``, shutting its generator down."""

    activity: str


class Reorder(Command, tag="reorder", kw_only=True):
    """Move ``activity`` to index ``position`` in the selected list."""

    activity: str
    position: Annotated[int, msgspec.Meta(ge=0)]


class GetReady(Command, tag="get_ready", kw_only=True):
    """Activate every selected generator and generate its script (Get Ready Button)."""


class Start(Command, tag="start", kw_only=True):
    """Push the not yet completed activities' scripts on the Block Reader (Start Button)."""


class Stop(Command, tag="stop", kw_only=True):
    """Interrupt the running activities (Stop Button)."""


class Restart(Command, tag="restart", kw_only=True):
    """Every activity back to not yet completed (Restart Button)."""


class Clear(Command, tag="clear", kw_only=True):
    """Deselect every activity (Clear Button)."""


OperatorCommand = (
    ListActivities | Add | Remove | Reorder | GetReady | Start | Stop | Restart | Clear
)
"""One command from the operator's app, console or scenario."""

VERBS: Final[tuple[str, ...]] = tuple(c.__struct_config__.tag for c in get_args(OperatorCommand))  # type: ignore[misc]
"""Every command's tag, in the union's order."""


def describe(command: OperatorCommand) -> str:
    """The command on one line, without its id: ``add test_dance tempo=fast``."""
    match command:
        case Add():
            options = (f"{k}={v}" for k, v in sorted(command.options.items()))
            parts = [command.activity, *options]
        case Remove():
            parts = [command.activity]
        case Reorder():
            parts = [command.activity, f"position={command.position}"]
        case _:
            parts = []
    return " ".join([command.verb, *(p for p in parts if p)])
