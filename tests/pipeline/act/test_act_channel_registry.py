"""The channel registry covers every channel, block field, item Struct and command exactly once."""

from __future__ import annotations

from typing import get_args

import msgspec
import pytest
from oimi.pipeline.act.channels import CHANNEL_ORDER
from oimi.pipeline.messages import (
    CHANNELS,
    ActuatorCommand,
    AudioOut,
    Channel,
    InstructionBlock,
    Led,
    Move,
    Source,
)


def test_every_channel_is_a_row_and_every_row_a_block_field() -> None:
    assert [spec.channel for spec in CHANNELS] == list(Channel) == list(CHANNEL_ORDER)
    fields = {f.name: f.type for f in msgspec.structs.fields(InstructionBlock)}
    for spec in CHANNELS:
        assert fields[spec.field] == tuple[spec.item, ...]
    assert set(fields) - {spec.field for spec in CHANNELS} == {"flagged"}


def test_every_row_names_its_command_tagged_by_its_channel() -> None:
    assert get_args(ActuatorCommand) == tuple(spec.command for spec in CHANNELS)
    for spec in CHANNELS:
        command = spec.command(source=Source.SCRIPT, stop=True)
        assert command.channel is spec.channel
        encoded = msgspec.json.encode(command)
        head = f'{{"channel":"{spec.channel}","source":"script","stop":true'
        assert encoded.decode().startswith(head)
        assert msgspec.json.decode(encoded, type=ActuatorCommand) == command


def test_a_command_carries_only_its_own_channel_fields() -> None:
    with pytest.raises(msgspec.ValidationError, match="unknown field `r`"):
        msgspec.json.decode(b'{"channel":"move","source":"script","r":1.0}', type=ActuatorCommand)


def test_a_block_gives_its_items_per_channel() -> None:
    move = Move(v_x=0.1, v_y=0.0, v_theta=0.0, wait_t=0, duration=10)
    led = Led(r=1.0, g=0.0, b=0.0, turnas=1, wait_t=0, duration=10)
    audio = AudioOut(track_path="a.wav", wait_t=0, duration=10)
    block = InstructionBlock(move=(move,), led=(led,), audioout=(audio,))
    assert block.channel_items() == {
        Channel.MOVE: (move,),
        Channel.LED: (led,),
        Channel.AUDIO: (audio,),
    }
