"""The timeline of one channel: wait, act, explicit stop, next item."""

from oimi.pipeline.act.channels import ChannelCursor, Due, Phase, schedule
from oimi.pipeline.messages import AudioOut, Led, Move


def test_schedule_chains_items_from_due_times():
    items = [
        Move(v_x=0.1, v_y=0.0, v_theta=0.0, wait_t=30, duration=30),
        Move(v_x=0.2, v_y=0.0, v_theta=0.0, wait_t=0, duration=50),
        Move(v_x=0.3, v_y=0.0, v_theta=0.0, wait_t=10, duration=0),
    ]
    assert schedule(items) == (
        Due(30, 0, Phase.ACT),
        Due(60, 0, Phase.STOP),
        Due(60, 1, Phase.ACT),
        Due(110, 1, Phase.STOP),
        Due(120, 2, Phase.ACT),
        Due(120, 2, Phase.STOP),
    )


def test_schedule_counts_negative_times_as_zero():
    items = [AudioOut(track_path="a.wav", wait_t=-5, duration=-10)]
    assert schedule(items) == (Due(0, 0, Phase.ACT), Due(0, 0, Phase.STOP))


def test_cursor_takes_each_event_once_in_order():
    cursor = ChannelCursor([Led(r=1, g=0, b=0, turnas=1, wait_t=20, duration=40)])
    assert cursor.take_due(19) == []
    assert cursor.index == 0
    assert cursor.take_due(100) == [Due(20, 0, Phase.ACT), Due(60, 0, Phase.STOP)]
    assert cursor.take_due(200) == []
    assert cursor.done
    assert cursor.index == 1


def test_empty_channel_is_done_at_once():
    cursor = ChannelCursor([])
    assert cursor.done
    assert cursor.index == 0
