"""The joystick's dead-man guard: one state per tick, button presses kept, lost links stop."""

from __future__ import annotations

from scenarios.live.inputs import NEUTRAL, JoystickGuard, Pad

DRIVE = Pad(left_y=1.0, buttons=("LB",))


def test_states_come_one_per_tick_and_stick_moves_merge():
    guard = JoystickGuard()
    guard.receive("a", Pad(left_y=0.2, buttons=("LB",)), now_s=0.0)
    guard.receive("a", Pad(left_y=0.4, buttons=("LB",)), now_s=0.01)
    guard.receive("a", Pad(left_y=0.4, buttons=("LB", "X")), now_s=0.01)
    guard.receive("a", Pad(left_y=0.4, buttons=("LB",)), now_s=0.01)
    taken = [guard.take(now_s=0.02) for _ in range(4)]
    assert taken == [
        Pad(left_y=0.4, buttons=("LB",)),
        Pad(left_y=0.4, buttons=("LB", "X")),
        Pad(left_y=0.4, buttons=("LB",)),
        None,
    ]


def test_a_heartbeat_keeps_the_lock_and_silence_releases_it():
    guard = JoystickGuard(timeout_s=0.5)
    guard.receive("a", DRIVE, now_s=0.0)
    assert guard.take(now_s=0.0) == DRIVE
    guard.receive("a", DRIVE, now_s=0.4)  # heartbeat: same state, nothing to apply
    assert guard.take(now_s=0.8) is None
    assert guard.take(now_s=0.95) == NEUTRAL
    assert guard.released == ["no joystick heartbeat for 500 ms"]
    assert guard.take(now_s=2.0) is None


def test_the_owner_disconnecting_releases_the_lock_but_another_client_does_not():
    guard = JoystickGuard()
    guard.receive("a", DRIVE, now_s=0.0)
    guard.take(now_s=0.0)
    guard.lost("b")
    assert guard.take(now_s=0.1) is None
    guard.lost("a")
    assert guard.take(now_s=0.1) == NEUTRAL
    assert guard.released == ["the joystick's client disconnected"]


def test_a_press_released_before_any_tick_never_reaches_the_robot():
    guard = JoystickGuard()
    guard.receive("a", DRIVE, now_s=0.0)
    guard.lost("a")
    assert guard.take(now_s=0.01) is None
