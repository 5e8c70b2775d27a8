"""Speed clamps, the acceleration ramp and the limits' own validation."""

import math

import msgspec
import pytest
from oimi.pipeline.act.limits import (
    RobotLimits,
    Velocity,
    clamp_velocity,
    fields,
    ramp_velocity,
)
from oimi.pipeline.act.safety import Supervised, Verdict
from oimi.pipeline.act.separation import Constraint
from oimi.pipeline.events import SafetyZone

LIMITS = RobotLimits()


def test_linear_speed_is_scaled_by_magnitude_keeping_direction():
    velocity, reports = clamp_velocity(Velocity(3.0, 4.0, 0.0), LIMITS)
    assert velocity.v_x == pytest.approx(0.3)
    assert velocity.v_y == pytest.approx(0.4)
    assert reports == ("move: speed |(v_x, v_y)| 5.0 m/s > max 0.5 m/s, scaled to (0.3, 0.4)",)


def test_single_axis_clamp_names_the_axis():
    velocity, reports = clamp_velocity(Velocity(0.0, -2.0, 0.0), LIMITS, what="move[1]")
    assert velocity == (0.0, -0.5, 0.0)
    assert reports == ("move[1]: v_y -2.0 m/s > max 0.5 m/s, clamped to -0.5",)


def test_angular_speed_is_cut_keeping_sign():
    velocity, reports = clamp_velocity(Velocity(0.1, 0.0, -3.0), LIMITS)
    assert velocity == (0.1, 0.0, -1.5)
    assert reports == ("move: v_theta -3.0 rad/s > max 1.5 rad/s, clamped to -1.5",)


def test_speed_within_limits_is_untouched():
    velocity, reports = clamp_velocity(Velocity(0.3, -0.4, 1.5), LIMITS)
    assert velocity == (0.3, -0.4, 1.5)
    assert reports == ()


def test_non_finite_speed_becomes_zero_with_a_report():
    velocity, reports = clamp_velocity(Velocity(math.nan, 0.1, math.inf), LIMITS)
    assert velocity == (0.0, 0.1, 0.0)
    assert reports == (
        "move: v_x nan is not a number, replaced by 0.0",
        "move: v_theta inf is not a number, replaced by 0.0",
    )


def test_ramp_changes_linear_velocity_by_at_most_max_accel_per_step():
    # 1 m/s² over 20 ms: 0.02 m/s along the direction of the change
    after = ramp_velocity(Velocity(), Velocity(0.3, 0.4, 0.0), LIMITS, dt_ms=20)
    assert after.v_x == pytest.approx(0.012)
    assert after.v_y == pytest.approx(0.016)
    assert math.hypot(after.v_x, after.v_y) == pytest.approx(0.02)


def test_ramp_changes_angular_velocity_by_at_most_max_angular_accel_per_step():
    after = ramp_velocity(Velocity(0.0, 0.0, 1.0), Velocity(0.0, 0.0, -1.0), LIMITS, dt_ms=100)
    assert after.v_theta == pytest.approx(0.7)


def test_ramp_reaches_the_target_exactly_within_one_step():
    target = Velocity(0.1, 0.0, 0.05)
    assert ramp_velocity(Velocity(0.09, 0.0, 0.0), target, LIMITS, dt_ms=20) == target


@pytest.mark.parametrize("field", ["max_speed_mps", "max_angular_accel_radps2"])
def test_non_positive_limits_are_rejected(field):
    with pytest.raises(ValueError, match=f"robot limit `{field}` must be a positive number"):
        RobotLimits(**{field: 0.0})


def test_limits_decode_from_a_scenario_with_a_path_in_the_error():
    assert msgspec.json.decode(b'{"max_speed_mps": 0.3}', type=RobotLimits).max_speed_mps == 0.3
    with pytest.raises(msgspec.ValidationError, match="max_speed_mps"):
        msgspec.json.decode(b'{"max_speed_mps": -1}', type=RobotLimits)


def test_the_fast_builds_spell_out_the_defaults_of_their_classes() -> None:
    """``limits.fields`` builds the supervisor's per-tick NamedTuples without their
    ``__new__``, every field given, defaults spelled out at each site (safety.py: a stand's
    and an unbound verdict, a verdict with no event, a held human's constraint). A default
    changed in its class must change at those sites too: this pins the defaults they spell."""
    velocity = Velocity(0.1, -0.2, 0.3)
    assert fields(Verdict, (velocity, None, "", None)) == Verdict(velocity)
    assert fields(Supervised, (Verdict(velocity), None)) == Supervised(Verdict(velocity))
    held = ("h", 0.1, 1.0, 0.0, 0.0, 0.5, SafetyZone.STOP, 1.5, 2.0)
    assert fields(Constraint, (*held, 0.0, 0.0)) == Constraint(*held)
    assert fields(Velocity, (0.1, -0.2, 0.3)) == velocity
