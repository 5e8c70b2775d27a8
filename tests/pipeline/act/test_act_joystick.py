"""The joystick: mapping, safety lock, override, blocking mode, interrupt, safety stop."""

import msgspec
import pytest
from oimi.pipeline.act.actuator import Actuator, ActuatorStep
from oimi.pipeline.act.joystick import read_pad
from oimi.pipeline.act.limits import RobotLimits
from oimi.pipeline.events import JoystickInput, Source
from oimi.pipeline.messages import InstructionBlock, Led, Move

TICK_MS = 20
LIMITS = RobotLimits()


def pad(*buttons: str, left_x=0.0, left_y=0.0, right_x=0.0) -> JoystickInput:
    return JoystickInput(
        tick=0, time_ms=0, left_x=left_x, left_y=left_y, right_x=right_x, buttons=buttons
    )


def led_block(*, dur: int, wait: int = 0) -> InstructionBlock:
    return InstructionBlock(led=(Led(r=0, g=1, b=0, turnas=1, wait_t=wait, duration=dur),))


def move_block(v_x: float, *, dur: int, wait: int = 0) -> InstructionBlock:
    return InstructionBlock(move=(Move(v_x=v_x, v_y=0, v_theta=0, wait_t=wait, duration=dur),))


class Session:
    """An actuator driven tick by tick with pad inputs at given times."""

    def __init__(self, block: InstructionBlock | None = None):
        self.actuator = Actuator(LIMITS, tick_ms=TICK_MS)
        if block is not None:
            self.actuator.issue(block, changed=False, now_ms=0)
        self.steps: dict[int, ActuatorStep] = {}

    def run(self, stop_ms: int, pads: dict[int, JoystickInput] | None = None) -> "Session":
        start = max(self.steps, default=-TICK_MS) + TICK_MS
        for t in range(start, stop_ms + 1, TICK_MS):
            if pads and t in pads:
                self.actuator.joystick(pads[t], now_ms=t)
            self.steps[t] = self.actuator.step(now_ms=t)
        return self

    def commands(self, channel: str) -> dict[int, list]:
        return {
            t: [(c.source, c.stop) for c in s.commands if c.channel == channel]
            for t, s in self.steps.items()
            if any(c.channel == channel for c in s.commands)
        }


# --------------------------------------------------------------- mapping


@pytest.mark.parametrize(
    ("stick", "expected"),
    [
        ({"left_y": 1.0}, (0.5, 0.0, 0.0)),
        ({"left_y": -1.0}, (-0.5, 0.0, 0.0)),
        ({"left_x": 1.0}, (0.0, -0.5, 0.0)),
        ({"right_x": 1.0}, (0.0, 0.0, -1.5)),
        ({"right_x": -1.0}, (0.0, 0.0, 1.5)),
        ({"left_y": 0.09, "right_x": -0.1}, (0.0, 0.0, 0.0)),
        ({"left_y": 0.55}, (0.25, 0.0, 0.0)),
    ],
)
def test_sticks_map_to_body_speeds_with_full_deflection_at_the_limits(stick, expected):
    velocity = read_pad(pad("LB", **stick), LIMITS).velocity
    assert velocity == pytest.approx(expected)


def test_a_diagonal_stick_is_no_faster_than_a_straight_push():
    velocity = read_pad(pad("LB", left_x=1.0, left_y=1.0), LIMITS).velocity
    assert (velocity.v_x**2 + velocity.v_y**2) ** 0.5 == pytest.approx(0.5)
    assert velocity.v_x == pytest.approx(-velocity.v_y)


def test_odd_pad_values_are_noted():
    state = read_pad(pad("LB", "Z", left_y=3.0), LIMITS)
    assert state.velocity.v_x == pytest.approx(0.5)
    assert state.notes == (
        "joystick: unknown button 'Z' ignored",
        "joystick: left_y 3.0 outside [-1, 1], limited to the edge",
    )


# ------------------------------------------------------------- safety lock


def test_input_without_the_lock_is_ignored_with_a_note():
    session = Session(move_block(0.2, dur=1000)).run(100, {40: pad("RB", left_y=1.0)})
    assert session.steps[40].notes == ("joystick: input ignored without the safety lock (LB)",)
    assert session.commands("move") == {0: [(Source.SCRIPT, False)]}
    assert not session.actuator.engaged


def test_a_neutral_pad_without_the_lock_is_ignored_silently():
    session = Session().run(20, {20: pad()})
    assert session.steps[20].notes == ()


def test_the_joystick_drives_while_the_lock_is_held_issuing_only_changes():
    pads = {
        20: pad("LB", left_y=1.0),
        40: pad("LB", left_y=1.0),
        60: pad("LB", left_y=1.0, right_x=0.5),
    }
    session = Session().run(80, pads)
    assert session.commands("move") == {
        20: [(Source.JOYSTICK, False)],
        60: [(Source.JOYSTICK, False)],
    }
    command = session.steps[60].commands[0]
    assert (command.v_x, command.v_theta) == pytest.approx((0.5, -1.5 * 0.4 / 0.9))
    assert session.steps[40].outputs.v_x == pytest.approx(0.04)
    assert session.actuator.engaged


def test_releasing_the_lock_issues_a_safety_stop_at_once():
    pads = {20: pad("LB", left_y=1.0), 200: pad(left_y=1.0)}
    session = Session().run(400, pads)
    stop = session.steps[200].commands
    assert [(c.source, c.stop, c.v_x) for c in stop] == [(Source.SAFETY, True, 0.0)]
    assert session.steps[200].notes == ("joystick: safety lock released, robot stopped",)
    # the body stops in the same tick (a protective stop, not ramped down), then stays still
    assert session.steps[180].outputs.v_x == pytest.approx(0.18)
    assert session.steps[180].outputs.brake is False
    assert session.steps[200].outputs.v_x == 0.0
    assert session.steps[200].outputs.brake is True
    assert session.steps[220].outputs.v_x == 0.0
    assert session.steps[220].outputs.brake is False


# ------------------------------------------------------------ non-blocking


def test_non_blocking_override_keeps_the_block_time_and_the_other_channels():
    block = InstructionBlock(
        move=(Move(v_x=0.2, v_y=0, v_theta=0, wait_t=0, duration=200),),
        led=(Led(r=0, g=1, b=0, turnas=1, wait_t=0, duration=300),),
    )
    pads = {100: pad("LB", left_y=-1.0), 260: pad("LB", left_y=-1.0)}
    session = Session(block).run(400, pads)
    assert session.commands("move") == {
        0: [(Source.SCRIPT, False)],
        100: [(Source.JOYSTICK, False)],
    }
    assert session.steps[200].notes == ("move[0]: script stop overridden by the joystick",)
    # the block's clock went on: the LED still stops at 300 ms and the block is done then
    assert session.commands("led") == {0: [(Source.SCRIPT, False)], 300: [(Source.SCRIPT, True)]}
    assert session.steps[300].done
    assert session.steps[300].outputs.v_x < 0


def test_a_script_move_falling_due_under_the_joystick_is_overridden():
    pads = {0: pad("LB")}
    session = Session(move_block(0.2, wait=40, dur=40)).run(100, pads)
    assert session.steps[40].notes == ("move[0]: script command overridden by the joystick",)
    assert session.commands("move") == {0: [(Source.JOYSTICK, False)]}
    assert all(s.outputs.v_x == 0.0 for s in session.steps.values())


def test_after_the_release_the_script_moves_again_only_at_its_next_command():
    block = InstructionBlock(
        move=(
            Move(v_x=0.2, v_y=0, v_theta=0, wait_t=0, duration=200),
            Move(v_x=0.3, v_y=0, v_theta=0, wait_t=100, duration=100),
        )
    )
    pads = {60: pad("LB"), 120: pad()}
    session = Session(block).run(400, pads)
    assert session.commands("move") == {
        0: [(Source.SCRIPT, False)],
        60: [(Source.JOYSTICK, False)],
        120: [(Source.SAFETY, True)],
        200: [(Source.SCRIPT, True)],
        300: [(Source.SCRIPT, False)],
        400: [(Source.SCRIPT, True)],
    }
    assert session.steps[280].outputs.v_x == 0.0


# ---------------------------------------------------------------- blocking


def test_blocking_mode_freezes_the_block_and_resumes_where_it_was():
    pads = {100: pad("LB", "RB", left_y=0.5), 300: pad()}
    session = Session(led_block(wait=40, dur=200)).run(600, pads)
    assert session.actuator.frozen is False
    # due at 240 ms of block time: 200 ms frozen shift it to 440
    assert session.commands("led") == {40: [(Source.SCRIPT, False)], 440: [(Source.SCRIPT, True)]}
    assert session.steps[420].done is False
    assert session.steps[440].done
    assert session.steps[200].outputs.led == (0.0, 1.0, 0.0)


def test_letting_go_of_rb_with_the_lock_held_ends_the_freeze():
    pads = {100: pad("LB", "RB"), 200: pad("LB")}
    session = Session(led_block(dur=200)).run(400, pads)
    assert session.commands("led")[300] == [(Source.SCRIPT, True)]
    assert session.steps[200].notes == ("joystick: non-blocking mode",)


def test_rb_without_the_lock_does_not_freeze():
    session = Session(led_block(dur=200)).run(300, {100: pad("RB")})
    assert session.commands("led")[200] == [(Source.SCRIPT, True)]


def test_a_block_issued_while_frozen_waits_for_the_freeze_to_end():
    session = Session().run(40, {0: pad("LB", "RB")})
    session.actuator.issue(led_block(dur=100), changed=False, now_ms=60)
    session.run(300, {100: pad()})
    assert session.commands("led") == {100: [(Source.SCRIPT, False)], 200: [(Source.SCRIPT, True)]}


# --------------------------------------------------------------- interrupt


def test_interrupt_freezes_the_block_until_the_next_engagement_of_the_lock():
    pads = {
        100: pad("LB", "X"),
        120: pad("LB"),
        200: pad(),  # released: still frozen
        260: pad("LB"),  # engaged again: resumes
        280: pad(),
    }
    session = Session(led_block(dur=200)).run(600, pads)
    assert session.steps[100].notes[-1] == (
        "joystick: block execution interrupted until the next engagement of the lock"
    )
    assert session.steps[260].notes == (
        "joystick: safety lock engaged, the joystick drives",
        "joystick: block execution resumed",
    )
    # 160 ms frozen (100 -> 260): the stop due at 200 comes at 360
    assert session.commands("led") == {0: [(Source.SCRIPT, False)], 360: [(Source.SCRIPT, True)]}


def test_holding_x_does_not_interrupt_again():
    pads = {100: pad("LB", "X"), 140: pad("LB", "X", left_y=1.0)}
    session = Session(led_block(dur=200)).run(200, pads)
    assert sum("interrupted" in n for s in session.steps.values() for n in s.notes) == 1
    assert session.actuator.frozen


def test_x_without_the_lock_is_ignored():
    session = Session(led_block(dur=200)).run(300, {100: pad("X")})
    assert not session.actuator.frozen
    assert session.commands("led")[200] == [(Source.SCRIPT, True)]


# ------------------------------------------------------------- determinism


def test_same_inputs_give_identical_steps():
    block = InstructionBlock(
        move=(Move(v_x=3.0, v_y=1.0, v_theta=0.5, wait_t=20, duration=300),),
        led=(Led(r=1, g=0, b=0, turnas=1, wait_t=0, duration=150),),
    )
    pads = {
        60: pad("LB", left_y=0.7, right_x=-0.3),
        100: pad("LB", "RB", left_x=0.4),
        160: pad("LB", "X"),
        220: pad(),
        300: pad("LB"),
        340: pad(),
    }

    def encoded() -> list[bytes]:
        session = Session(block).run(800, pads)
        return [msgspec.json.encode(session.steps[t]) for t in sorted(session.steps)]

    assert encoded() == encoded()
