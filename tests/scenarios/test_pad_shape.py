"""One pad-state shape: every layer's joystick message converts to ``Pad`` and back."""

from __future__ import annotations

import msgspec
import pytest
from oimi.pipeline.events import Button, JoystickInput, LockRelease, Pad
from oimi.scenarios.schema import JoystickEvent

from oimi.live import protocol

DRIVE = Pad(left_x=0.25, left_y=-0.5, right_x=1.0, buttons=(Button.LB, Button.X))


def test_a_tick_input_is_the_pad_at_that_tick_and_gives_it_back() -> None:
    joystick = DRIVE.at(tick=7, time_ms=140, release=LockRelease.OPERATOR)
    assert (joystick.tick, joystick.time_ms, joystick.release) == (7, 140, LockRelease.OPERATOR)
    assert joystick.pad == DRIVE


def test_the_recorded_input_keeps_its_flat_json_with_button_names() -> None:
    encoded = msgspec.json.encode(DRIVE.at(tick=1, time_ms=20))
    assert b'"buttons":["LB","X"]' in encoded
    assert b'"pad"' not in encoded
    assert msgspec.json.decode(encoded, type=JoystickInput).pad == DRIVE


def test_the_live_request_and_the_scenario_event_give_the_same_pad() -> None:
    fields = {"left_x": 0.25, "left_y": -0.5, "right_x": 1.0, "buttons": ["LB", "X"]}
    request = msgspec.json.decode(
        msgspec.json.encode({"cmd": "joystick", "id": 1, **fields}), type=protocol.AnyRequest
    )
    event = msgspec.convert({"kind": "joystick", "at_s": 1.0, **fields}, JoystickEvent)
    assert request.pad == event.pad == DRIVE
    assert DRIVE.locked and not Pad(buttons=(Button.RB,)).locked


def test_an_unknown_button_is_refused_where_it_enters() -> None:
    with pytest.raises(msgspec.ValidationError, match="buttons"):
        msgspec.convert({"kind": "joystick", "at_s": 0.0, "buttons": ["Z"]}, JoystickEvent)
