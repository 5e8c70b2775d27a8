"""The Actuator running instruction blocks: timing per channel, issue/restart, clamps, ramp."""

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oimi.pipeline.act.actuator import Actuator, ActuatorStep
from oimi.pipeline.act.limits import RobotLimits, Velocity
from oimi.pipeline.events import Source
from oimi.pipeline.messages import (
    AudioCommand,
    AudioOut,
    InstructionBlock,
    Led,
    LedCommand,
    Move,
)

TICK_MS = 20
LIMITS = RobotLimits()


def move(v_x=0.1, v_y=0.0, v_theta=0.0, *, wait=0, dur=100) -> Move:
    return Move(v_x=v_x, v_y=v_y, v_theta=v_theta, wait_t=wait, duration=dur)


def led(r=1.0, g=0.0, b=0.0, *, turnas=1, wait=0, dur=100) -> Led:
    return Led(r=r, g=g, b=b, turnas=turnas, wait_t=wait, duration=dur)


def audio(track="hello.wav", *, wait=0, dur=100) -> AudioOut:
    return AudioOut(track_path=track, wait_t=wait, duration=dur)


def run(actuator: Actuator, start_ms: int, stop_ms: int) -> dict[int, ActuatorStep]:
    """Step every tick from ``start_ms`` to ``stop_ms`` inclusive."""
    return {t: actuator.step(now_ms=t) for t in range(start_ms, stop_ms + 1, TICK_MS)}


def started(block: InstructionBlock, now_ms: int = 0) -> Actuator:
    actuator = Actuator(LIMITS, tick_ms=TICK_MS)
    actuator.issue(block, changed=False, now_ms=now_ms)
    return actuator


def ticks_with_commands(steps: dict[int, ActuatorStep]) -> dict[int, list[tuple]]:
    return {
        t: [(c.channel, c.stop) for c in step.commands]
        for t, step in steps.items()
        if step.commands
    }


# ---------------------------------------------------------------- timing


def test_move_waits_then_acts_then_stops():
    steps = run(started(InstructionBlock(move=(move(0.2, wait=40, dur=60),))), 0, 200)
    assert ticks_with_commands(steps) == {40: [("move", False)], 100: [("move", True)]}
    assert steps[40].commands[0].v_x == 0.2
    assert steps[40].commands[0].source is Source.SCRIPT
    assert [t for t, s in steps.items() if s.done] == list(range(100, 201, TICK_MS))


def test_led_waits_then_lights_then_turns_off():
    steps = run(started(InstructionBlock(led=(led(0.0, 0.5, 1.0, wait=20, dur=40),))), 0, 100)
    assert ticks_with_commands(steps) == {20: [("led", False)], 60: [("led", True)]}
    assert steps[0].outputs.led == (0.0, 0.0, 0.0)
    assert steps[20].outputs.led == (0.0, 0.5, 1.0)
    assert steps[40].outputs.led == (0.0, 0.5, 1.0)
    assert steps[60].outputs.led == (0.0, 0.0, 0.0)


def test_audio_waits_then_plays_then_stops_the_track():
    steps = run(started(InstructionBlock(audioout=(audio("song.ogg", wait=60, dur=20),))), 0, 100)
    assert ticks_with_commands(steps) == {60: [("audio", False)], 80: [("audio", True)]}
    assert steps[80].commands[0].track_path == "song.ogg"
    assert [s.outputs.audio for s in steps.values()] == ["", "", "", "song.ogg", "", ""]


def test_events_fall_on_the_first_tick_at_or_after_their_due_time():
    steps = run(started(InstructionBlock(led=(led(wait=30, dur=15),))), 0, 100)
    assert ticks_with_commands(steps) == {40: [("led", False)], 60: [("led", True)]}


def test_items_of_a_channel_follow_each_other_without_drift():
    block = InstructionBlock(move=(move(0.1, wait=30, dur=30), move(0.2, wait=30, dur=30)))
    steps = run(started(block), 0, 200)
    # due: act 30, stop 60, act 90, stop 120 (from the items' numbers, not the ticks)
    assert ticks_with_commands(steps) == {
        40: [("move", False)],
        60: [("move", True)],
        100: [("move", False)],
        120: [("move", True)],
    }


def test_stop_and_next_act_at_the_same_time_come_in_that_order():
    block = InstructionBlock(led=(led(1, 0, 0, dur=40), led(0, 1, 0, dur=40)))
    steps = run(started(block), 0, 80)
    assert [(c.stop, c.g) for c in steps[40].commands] == [(True, 0.0), (False, 1.0)]
    assert steps[40].outputs.led == (0.0, 1.0, 0.0)


def test_channels_run_in_parallel_in_a_stable_order_within_a_tick():
    block = InstructionBlock(
        audioout=(audio(wait=20, dur=20),), led=(led(wait=20, dur=20),), move=(move(wait=20),)
    )
    steps = run(started(block), 0, 40)
    assert [c.channel for c in steps[20].commands] == ["move", "led", "audio"]


def test_block_is_done_only_when_every_channel_is_done():
    block = InstructionBlock(move=(move(dur=40),), audioout=(audio(wait=20, dur=100),))
    actuator = started(block)
    steps = run(actuator, 0, 160)
    assert not steps[40].done
    assert not steps[100].done
    assert steps[120].done
    assert actuator.done


def test_empty_block_is_done_at_once():
    actuator = started(InstructionBlock())
    assert actuator.done
    step = actuator.step(now_ms=0)
    assert step.done
    assert step.commands == ()


def test_no_block_is_done_and_still():
    actuator = Actuator(LIMITS, tick_ms=TICK_MS)
    assert actuator.done
    assert actuator.progress == (0, 0, 0)
    assert actuator.step(now_ms=0).outputs.v_x == 0.0


def test_zero_duration_item_acts_and_stops_in_one_tick():
    steps = run(started(InstructionBlock(led=(led(wait=20, dur=0),))), 0, 40)
    assert ticks_with_commands(steps) == {20: [("led", False), ("led", True)]}
    assert steps[20].outputs.led == (0.0, 0.0, 0.0)
    assert steps[20].done


def test_zero_wait_acts_on_the_tick_the_block_is_issued():
    actuator = Actuator(LIMITS, tick_ms=TICK_MS)
    actuator.step(now_ms=0)
    actuator.issue(InstructionBlock(audioout=(audio("a.wav", wait=0),)), changed=False, now_ms=60)
    step = actuator.step(now_ms=60)
    assert [(c.channel, c.track_path) for c in step.commands] == [("audio", "a.wav")]


def test_turnas_zero_means_lights_off_for_that_item():
    steps = run(started(InstructionBlock(led=(led(1, 1, 1, turnas=0, dur=40),))), 0, 40)
    command = steps[0].commands[0]
    assert (command.r, command.g, command.b, command.stop) == (0.0, 0.0, 0.0, False)
    assert steps[20].outputs.led == (0.0, 0.0, 0.0)


def test_progress_gives_the_item_each_channel_executes():
    block = InstructionBlock(
        move=(move(dur=40), move(dur=40)), led=(led(dur=20),), audioout=(audio(dur=200),)
    )
    actuator = started(block)
    seen = {}
    for t in range(0, 101, TICK_MS):
        actuator.step(now_ms=t)
        seen[t] = actuator.progress
    assert seen[0] == (0, 0, 0)
    assert seen[20] == (0, 1, 0)
    assert seen[40] == (1, 1, 0)
    assert seen[80] == (2, 1, 0)


def test_negative_times_are_counted_as_zero_with_a_note():
    actuator = started(InstructionBlock(led=(led(wait=-10, dur=40),)))
    step = actuator.step(now_ms=0)
    assert step.notes == ("led[0]: negative wait_t -10 or duration 40 ms counted as 0",)
    assert step.commands[0].channel == "led"


def test_time_going_back_is_refused():
    actuator = started(InstructionBlock(), now_ms=100)
    with pytest.raises(ValueError, match="time went back from 100 ms to 80 ms"):
        actuator.step(now_ms=80)


def test_tick_must_be_positive():
    with pytest.raises(ValueError, match="tick_ms must be positive, got 0"):
        Actuator(LIMITS, tick_ms=0)


# ----------------------------------------------------------------- issue


def test_a_different_block_starts_from_its_beginning_and_stops_the_old_one():
    old = InstructionBlock(led=(led(1, 0, 0, dur=1000),), audioout=(audio("old.wav", dur=1000),))
    new = InstructionBlock(led=(led(0, 0, 1, wait=40, dur=40),))
    actuator = started(old)
    run(actuator, 0, 100)
    actuator.issue(new, changed=False, now_ms=120)
    steps = run(actuator, 120, 240)
    assert steps[120].commands == (
        LedCommand(source=Source.SCRIPT, stop=True),
        AudioCommand(source=Source.SCRIPT, track_path="old.wav", stop=True),
    )
    assert steps[120].block == new
    assert steps[140].block is None
    assert steps[120].outputs.led == (0.0, 0.0, 0.0)
    assert steps[120].outputs.audio == ""
    assert ticks_with_commands({t: s for t, s in steps.items() if t > 120}) == {
        160: [("led", False)],
        200: [("led", True)],
    }


def test_changed_restarts_the_same_block_from_its_beginning():
    block = InstructionBlock(move=(move(0.2, wait=40, dur=100),))
    actuator = started(block)
    run(actuator, 0, 60)
    assert actuator.progress == (0, 0, 0)
    actuator.issue(block, changed=True, now_ms=80)
    steps = run(actuator, 80, 300)
    assert [(c.stop, c.v_x) for c in steps[80].commands] == [(True, 0.0)]
    assert ticks_with_commands(steps) == {
        80: [("move", True)],
        120: [("move", False)],
        220: [("move", True)],
    }


def test_the_same_block_again_is_a_no_op():
    actuator = started(InstructionBlock(led=(led(wait=40, dur=40),)))
    run(actuator, 0, 20)
    equal_copy = InstructionBlock(led=(led(wait=40, dur=40),))
    actuator.issue(equal_copy, changed=False, now_ms=40)
    steps = run(actuator, 40, 100)
    assert ticks_with_commands(steps) == {40: [("led", False)], 80: [("led", True)]}
    assert steps[40].block is None


def test_the_same_block_after_it_is_consumed_stays_consumed():
    block = InstructionBlock(audioout=(audio(dur=20),))
    actuator = started(block)
    run(actuator, 0, 40)
    actuator.issue(block, changed=False, now_ms=60)
    step = actuator.step(now_ms=60)
    assert step.done
    assert step.commands == ()


def test_issuing_none_drops_the_block_and_stops_its_channels():
    actuator = started(InstructionBlock(move=(move(0.2, dur=1000),), led=(led(dur=1000),)))
    run(actuator, 0, 40)
    actuator.issue(None, changed=True, now_ms=60)
    step = actuator.step(now_ms=60)
    assert [(c.channel, c.stop) for c in step.commands] == [("move", True), ("led", True)]
    assert actuator.done
    assert actuator.block is None


# ---------------------------------------------------------------- clamps


def test_a_speed_over_the_limit_is_clamped_and_reported_once():
    steps = run(started(InstructionBlock(move=(move(10.0, wait=20, dur=100),))), 0, 200)
    command = steps[20].commands[0]
    assert (command.v_x, command.v_y, command.clamped) == (0.5, 0.0, True)
    assert command.requested == (10.0, 0.0, 0.0)
    assert steps[20].clamps == ("move[0]: v_x 10.0 m/s > max 0.5 m/s, clamped to 0.5",)
    assert [t for t, s in steps.items() if s.clamps] == [20]
    assert max(abs(s.outputs.v_x) for s in steps.values()) <= 0.5


def test_diagonal_and_angular_speeds_are_clamped_by_magnitude():
    steps = run(started(InstructionBlock(move=(move(3.0, -4.0, 2.0),))), 0, 0)
    command = steps[0].commands[0]
    assert command.v_x == pytest.approx(0.3)
    assert command.v_y == pytest.approx(-0.4)
    assert command.v_theta == 1.5
    assert command.requested == (3.0, -4.0, 2.0)
    assert len(steps[0].clamps) == 2


def test_a_speed_within_the_limits_is_not_marked_clamped():
    command = run(started(InstructionBlock(move=(move(0.4),))), 0, 0)[0].commands[0]
    assert (command.clamped, command.requested) == (False, None)


def test_led_colour_outside_zero_one_is_clamped_and_reported():
    step = run(started(InstructionBlock(led=(led(2.0, -1.0, 0.5),))), 0, 0)[0]
    command = step.commands[0]
    assert (command.r, command.g, command.b, command.clamped) == (1.0, 0.0, 0.5, True)
    assert step.clamps == (
        "led[0]: r 2.0 outside [0, 1], clamped to 1.0",
        "led[0]: g -1.0 outside [0, 1], clamped to 0.0",
    )


# ------------------------------------------------------------------ ramp


def test_outputs_ramp_to_the_target_at_the_largest_acceleration():
    steps = run(started(InstructionBlock(move=(move(0.1, v_theta=0.3, dur=200),))), 0, 300)
    speeds = [round(steps[t].outputs.v_x, 6) for t in range(0, 141, TICK_MS)]
    assert speeds == [0.02, 0.04, 0.06, 0.08, 0.1, 0.1, 0.1, 0.1]
    assert steps[0].outputs.v_theta == pytest.approx(0.06)
    assert steps[100].outputs.v_theta == pytest.approx(0.3)
    # the stop at 200 ms decelerates at the same rate
    assert steps[200].outputs.v_x == pytest.approx(0.08)
    assert steps[300].outputs.v_x == 0.0


# ----------------------------------------------------------- determinism

timed = st.integers(min_value=0, max_value=120)
speeds = st.floats(min_value=-5, max_value=5, allow_nan=False)
moves = st.builds(Move, v_x=speeds, v_y=speeds, v_theta=speeds, wait_t=timed, duration=timed)
leds = st.builds(
    Led,
    r=st.just(1.0),
    g=st.just(0.5),
    b=st.just(0.0),
    turnas=st.sampled_from([0, 1]),
    wait_t=timed,
    duration=timed,
)
audios = st.builds(AudioOut, track_path=st.sampled_from(["a", "b"]), wait_t=timed, duration=timed)
blocks = st.builds(
    InstructionBlock,
    move=st.lists(moves, max_size=3).map(tuple),
    led=st.lists(leds, max_size=3).map(tuple),
    audioout=st.lists(audios, max_size=3).map(tuple),
)


def session(block: InstructionBlock) -> list[bytes]:
    actuator = started(block)
    return [msgspec.json.encode(actuator.step(now_ms=t)) for t in range(0, 1200, TICK_MS)]


@settings(max_examples=50, deadline=None)
@given(blocks)
def test_same_inputs_give_identical_steps_and_stay_within_limits(block):
    first = session(block)
    assert first == session(block)
    steps = [msgspec.json.decode(raw, type=ActuatorStep) for raw in first]
    for step in steps:
        speed = (step.outputs.v_x**2 + step.outputs.v_y**2) ** 0.5
        assert speed <= LIMITS.max_speed_mps + 1e-9
        assert abs(step.outputs.v_theta) <= LIMITS.max_angular_speed_radps + 1e-9
    # every channel ends at the sum of its items' times: the block is done by then
    end_ms = max(
        (
            sum(i.wait_t + i.duration for i in items)
            for items in (block.move, block.led, block.audioout)
        ),
        default=0,
    )
    done_at = next(i * TICK_MS for i, step in enumerate(steps) if step.done)
    assert end_ms <= done_at < end_ms + TICK_MS
    assert steps[-1].outputs.led == (0.0, 0.0, 0.0)
    assert steps[-1].outputs.audio == ""


@settings(max_examples=30, deadline=None)
@given(blocks, st.integers(min_value=0, max_value=59))
def test_the_velocity_is_what_each_steps_outputs_ask_for_a_hold_included(block, hold_at):
    """The loop hands the supervisor ``Actuator.velocity`` as the step's request."""
    actuator = started(block)
    for tick in range(60):
        out = actuator.step(now_ms=tick * TICK_MS).outputs
        assert tuple(actuator.velocity) == (out.v_x, out.v_y, out.v_theta)
        if tick == hold_at:  # the supervisor let less through: the next ramp starts there
            actuator.hold(Velocity(out.v_x / 2, 0.0, out.v_theta))
