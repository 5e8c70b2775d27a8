"""The channel registry covers every channel, block field and item Struct exactly once."""

from __future__ import annotations

import msgspec
from oimi.pipeline.act.channels import CHANNEL_ORDER
from oimi.pipeline.messages import CHANNELS, AudioOut, Channel, InstructionBlock, Led, Move


def test_every_channel_is_a_row_and_every_row_a_block_field() -> None:
    assert [spec.channel for spec in CHANNELS] == list(Channel) == list(CHANNEL_ORDER)
    fields = {f.name: f.type for f in msgspec.structs.fields(InstructionBlock)}
    for spec in CHANNELS:
        assert fields[spec.field] == tuple[spec.item, ...]
    assert set(fields) - {spec.field for spec in CHANNELS} == {"flagged"}


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
