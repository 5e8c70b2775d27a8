"""The pad's safety lock, shared by a scripted and a live pad: each way to let go of it
is released once, with its reason, and nothing else releases it."""

from __future__ import annotations

from oimi.pipeline.act.safety_lock import NEUTRAL, SafetyLock
from oimi.pipeline.events import Button, LockRelease, Pad

DRIVE = Pad(left_y=1.0, buttons=(Button.LB,))
STICK_ONLY = Pad(left_y=1.0)


def test_letting_go_of_the_lock_is_the_operators_release():
    lock = SafetyLock()
    assert lock.receive(DRIVE, now_s=0.0) is None
    assert lock.held
    assert lock.receive(STICK_ONLY, now_s=0.1) is LockRelease.OPERATOR
    assert not lock.held and lock.pad == STICK_ONLY  # the state itself, sticks and all
    assert lock.receive(NEUTRAL, now_s=0.2) is None  # already let go: no second release


def test_silence_while_holding_the_lock_is_a_heartbeat_release():
    lock = SafetyLock(timeout_s=0.5)
    lock.receive(DRIVE, now_s=0.0)
    lock.receive(DRIVE, now_s=0.4)  # a heartbeat: the same state
    assert lock.expire(now_s=0.9) is None  # exactly the timeout: still held
    assert lock.expire(now_s=0.95) is LockRelease.HEARTBEAT
    assert lock.pad == NEUTRAL
    assert lock.expire(now_s=5.0) is None


def test_a_lost_client_holding_the_lock_is_a_disconnection_release():
    lock = SafetyLock()
    lock.receive(DRIVE, now_s=0.0)
    assert lock.lost() is LockRelease.DISCONNECTED
    assert lock.pad == NEUTRAL
    assert lock.lost() is None


def test_nothing_releases_a_lock_that_is_not_held():
    lock = SafetyLock(timeout_s=0.5)
    lock.receive(STICK_ONLY, now_s=0.0)
    assert lock.expire(now_s=10.0) is None
    assert lock.lost() is None
    assert lock.pad == STICK_ONLY  # a lost client's unlocked state is kept as it was


def test_a_scripted_pad_without_a_timeout_never_expires():
    lock = SafetyLock()
    lock.receive(DRIVE, now_s=0.0)
    assert lock.expire(now_s=3600.0) is None
    assert lock.held
