"""The joystick's dead-man guard: the pad is a state (the latest wins, presses survive as
edges), and letting go, silence or a lost link release the lock at the next tick, saying why."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from oimi.pipeline.events import LockRelease

from oimi.live.inputs import NEUTRAL, JoystickGuard, Pad, Taken

DRIVE = Pad(left_y=1.0, buttons=("LB",))


def test_each_tick_takes_the_latest_state_and_keeps_a_press_between_ticks():
    guard = JoystickGuard()
    guard.receive("a", Pad(left_y=0.2, buttons=("LB",)), now_s=0.0)
    guard.receive("a", Pad(left_y=0.4, buttons=("LB",)), now_s=0.01)
    guard.receive("a", Pad(left_y=0.4, buttons=("LB", "X")), now_s=0.01)
    guard.receive("a", Pad(left_y=0.5, buttons=("LB",)), now_s=0.01)
    taken = [guard.take(now_s=0.02) for _ in range(3)]
    assert taken == [
        Taken(pad=Pad(left_y=0.5, buttons=("LB", "X"))),  # the latest sticks, X pressed
        Taken(pad=Pad(left_y=0.5, buttons=("LB",))),  # X let go
        None,
    ]


def test_a_backlog_of_states_then_letting_go_stops_at_the_next_tick():
    guard = JoystickGuard()
    for i in range(5000):  # far more than one per tick, a button toggling
        buttons = ("LB", "X") if i % 2 else ("LB",)
        guard.receive("a", Pad(left_y=1.0, buttons=buttons), now_s=0.001 * i)
    guard.receive("a", NEUTRAL, now_s=5.0)
    assert guard.take(now_s=5.0) is None  # the lock never reached the robot
    guard.receive("a", DRIVE, now_s=5.0)
    assert guard.take(now_s=5.0) == Taken(pad=DRIVE)
    for i in range(5000):
        guard.receive("a", Pad(left_y=1.0, buttons=("LB", "X") if i % 2 else ("LB",)), now_s=5.0)
    guard.receive("a", NEUTRAL, now_s=5.0)
    assert guard.take(now_s=5.01) == Taken(pad=NEUTRAL, release=LockRelease.OPERATOR)
    assert guard.take(now_s=5.02) is None


def test_a_heartbeat_keeps_the_lock_and_silence_releases_it():
    guard = JoystickGuard(timeout_s=0.5)
    guard.receive("a", DRIVE, now_s=0.0)
    assert guard.take(now_s=0.0) == Taken(pad=DRIVE)
    guard.receive("a", DRIVE, now_s=0.4)  # heartbeat: same state, nothing to apply
    assert guard.take(now_s=0.8) is None
    assert guard.take(now_s=0.95) == Taken(pad=NEUTRAL, release=LockRelease.HEARTBEAT)
    assert guard.take(now_s=2.0) is None


def test_the_owner_disconnecting_releases_the_lock_but_another_client_does_not():
    guard = JoystickGuard()
    guard.receive("a", DRIVE, now_s=0.0)
    guard.take(now_s=0.0)
    guard.lost("b")
    assert guard.take(now_s=0.1) is None
    guard.receive("a", Pad(left_y=0.5, buttons=("LB", "X")), now_s=0.1)  # pending: dropped
    guard.lost("a")
    assert guard.take(now_s=0.1) == Taken(pad=NEUTRAL, release=LockRelease.DISCONNECTED)
    assert guard.take(now_s=0.2) is None


def test_a_press_released_before_any_tick_never_reaches_the_robot():
    guard = JoystickGuard()
    guard.receive("a", DRIVE, now_s=0.0)
    guard.lost("a")
    assert guard.take(now_s=0.01) is None


pads = st.builds(
    Pad,
    left_y=st.sampled_from([0.0, 0.5, 1.0]),
    buttons=st.sampled_from([(), ("LB",), ("LB", "X"), ("X",)]),
)
events = st.lists(
    st.one_of(pads, st.just("tick"), st.just("lost"), st.just("silence")), max_size=60
)


@settings(max_examples=200, derandomize=True, deadline=None)
@given(events)
def test_a_tick_never_drives_on_a_state_older_than_the_latest(stream):
    """Whatever arrives, a locked input taken by a tick is the latest state (plus presses),
    and after a release or a loss nothing locked is taken until a new locked state comes."""
    guard = JoystickGuard(timeout_s=0.5)
    now = 0.0
    live = False  # the owner's latest state holds the lock and it is connected
    for event in stream:
        if event == "silence":
            now += 1.0
        elif event == "lost":
            guard.lost("a")
            live = False
        elif event == "tick":
            now += 0.02
            taken = guard.take(now_s=now)
            if taken is not None and taken.pad.locked:
                assert live and taken.pad.left_y == guard.latest.left_y
                assert set(guard.latest.buttons) <= set(taken.pad.buttons)
            if not guard.latest.locked:
                live = False
        else:
            guard.receive("a", event, now_s=now)
            live = event.locked


def test_a_polled_source_counts_in_the_tick_that_takes_it():
    """/joy over DDS is polled when a tick takes its input: not one tick late."""
    guard = JoystickGuard()
    arriving: list[Pad] = []
    guard.poll(lambda now_s: [guard.receive("ros2", p, now_s=now_s) for p in arriving])
    arriving.append(DRIVE)
    assert guard.take(now_s=0.02) == Taken(pad=DRIVE)
    arriving[:] = [NEUTRAL]
    assert guard.take(now_s=0.04) == Taken(pad=NEUTRAL, release=LockRelease.OPERATOR)
    arriving.clear()
    assert guard.take(now_s=0.06) is None
