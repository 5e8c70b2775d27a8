"""The pymunk world: omni-directional robot, humans, ball, contacts, determinism."""

from __future__ import annotations

import itertools
import math
import struct

import msgspec
import pymunk
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from oimi.pipeline.events import BodyState, WorldState, encode
from oimi.pipeline.messages import ActuatorOutputs
from oimi.scenarios.loader import parse_scenario
from oimi.scenarios.schema import BehaviourEvent, Leave, Scenario, Stand
from oimi.scenarios.simulation.bodies import STATE_DECIMALS, rounded, wrap_angle
from oimi.scenarios.simulation.humans import PACE, HumanDriver
from oimi.scenarios.simulation.world import World, stream_rng

STOP = ActuatorOutputs()


def scenario(text: str = "") -> Scenario:
    return parse_scenario(f'name = "world test"\n{text}'.encode()).scenario


def world(text: str = "", seed: int = 1) -> World:
    return World(scenario(text), stream_rng(seed, "world"))


def run(w: World, outputs: ActuatorOutputs, ticks: int, start: int = 0) -> int:
    for tick in range(start, start + ticks):
        w.step(outputs, tick=tick)
    return start + ticks


def test_robot_accelerates_within_its_limit_to_the_commanded_speed():
    w = world()  # 50 Hz, max_accel 1.0 m/s²: 0.02 m/s per tick
    speeds = []
    for tick in range(30):
        w.step(ActuatorOutputs(v_x=0.4), tick=tick)
        speeds.append(w.robot.velocity.x)
    assert speeds[0] == pytest.approx(0.02)
    assert all(b - a <= 0.02 + 1e-12 for a, b in itertools.pairwise(speeds))
    assert speeds[19] == pytest.approx(0.4)
    assert speeds[-1] == pytest.approx(0.4)


def test_robot_speed_is_clamped_to_its_maximum():
    w = world()  # 1 m/s² and 3 rad/s²: the limits are reached within 25 ticks
    run(w, ActuatorOutputs(v_x=3.0, v_y=3.0, v_theta=9.0), 40)
    assert w.robot.velocity.length == pytest.approx(0.5)
    assert w.robot.angular_velocity == pytest.approx(1.5)


def test_angular_speed_respects_the_angular_acceleration_limit():
    w = world()  # 3 rad/s² at 50 Hz: 0.06 rad/s per tick
    w.step(ActuatorOutputs(v_theta=1.0), tick=0)
    assert w.robot.angular_velocity == pytest.approx(0.06)


def test_body_frame_command_is_rotated_into_the_world_frame():
    w = world(f"[robot]\ntheta_rad = {math.pi / 2}\nmax_accel_mps2 = 2.0\n")
    run(w, ActuatorOutputs(v_x=0.3, v_y=0.1), 10)  # 0.04 m/s per tick: there after 8
    # facing +y: forward is world +y, left is world -x
    assert w.robot.velocity.x == pytest.approx(-0.1)
    assert w.robot.velocity.y == pytest.approx(0.3)
    assert w.robot_body_velocity()[:2] == pytest.approx((0.3, 0.1))


def test_robot_stops_dead_on_a_zero_command_without_drift():
    w = world()
    tick = run(w, ActuatorOutputs(v_x=0.5, v_y=0.2, v_theta=0.5), 50)
    tick = run(w, STOP, 40, tick)
    assert tuple(w.robot.velocity) == (0.0, 0.0)
    assert w.robot.angular_velocity == 0.0
    before = w.robot_pose()
    run(w, STOP, 50, tick)
    assert w.robot_pose() == before


def test_walls_stop_the_robot():
    w = world("[world]\nwidth_m = 4.0\n")
    run(w, ActuatorOutputs(v_x=0.5), 400)  # 8 s at 0.5 m/s: far beyond the wall
    x, _, _ = w.robot_pose()
    assert 4.0 - 0.3 - 0.01 <= x <= 4.0 - 0.3 + 0.01


def test_furniture_stops_the_robot():
    w = world(
        "[[world.obstacles]]\nid = 'table'\nx_m = 4.5\ny_m = 2.5\nwidth_m = 1.0\nheight_m = 2.0\n"
    )
    run(w, ActuatorOutputs(v_x=0.5), 300)
    assert w.robot_pose()[0] == pytest.approx(4.0 - 0.3, abs=0.01)


HUMAN_KICKS_BALL = """
[world]
objects = [{ id = "ball", x_m = 2.0, y_m = 1.0 }]
[[humans]]
id = "kid"
x_m = 0.8
y_m = 1.0
behaviour = [{ kind = "waypoints", waypoints = [[2.2, 1.0]], speed_mps = 1.0 }]
"""


def test_a_human_walking_into_the_ball_pushes_it_and_it_rolls_to_a_stop():
    w = world(HUMAN_KICKS_BALL)
    run(w, STOP, 100)
    ball = w.things[0].body
    assert ball.position.x > 2.6
    assert ball.velocity.length > 0 or ball.position.x > 2.6
    run(w, STOP, 500, 100)
    assert tuple(ball.velocity) == (0.0, 0.0)
    resting = ball.position.x
    run(w, STOP, 50, 600)
    assert ball.position.x == resting


APPROACHING_CHILD = """
[robot]
x_m = 3.0
y_m = 2.5
[[humans]]
id = "kid"
x_m = 1.0
y_m = 2.5
touchtype = "H"
behaviour = [{ kind = "approach", distance_m = 0.5 }]
"""


PUSHING_CHILD = APPROACHING_CHILD.replace('"approach"', '"follow"')
"""A child who keeps walking into the robot (follow closer than the sum of the radii)."""


def test_contacts_with_humans_are_reported_and_their_span_when_they_end():
    w = world(PUSHING_CHILD)
    reports = [w.step(STOP, tick=tick) for tick in range(150)]
    touching = [r.tick for r in reports if r.contacts == ("kid",)]
    assert touching
    assert w.state(tick=149, time_ms=2980).contacts == ("kid",)
    w.apply_event(BehaviourEvent(at_s=3.0, human="kid", segment=Leave()))
    later = [w.step(STOP, tick=tick) for tick in range(150, 160)]
    ended = [span for r in later for span in r.ended]
    assert len(ended) == 1
    assert ended[0].human == "kid"
    assert ended[0].touchtype == "H"
    assert ended[0].startingtime_ms == touching[0] * 20
    assert ended[0].duration_ms > 0


def test_a_pushed_robot_never_exceeds_its_speed_limit():
    # the child (1 m/s) keeps walking into the robot (0.5 m/s at most): pushed, the robot
    # goes no faster than its limit, during the contact and after it
    w = world(PUSHING_CHILD)
    speeds = []
    for tick in range(150):
        w.step(STOP, tick=tick)
        robot = w.state(tick=tick, time_ms=tick * 20).robot
        speeds.append(math.hypot(robot.vx_mps, robot.vy_mps))
    assert w.last_report.contacts == ("kid",)
    assert max(speeds) == pytest.approx(0.5)
    assert max(speeds) <= 0.5 + 1e-12


def test_approach_stops_at_the_distance_from_the_robot():
    w = world(APPROACHING_CHILD.replace("distance_m = 0.5", "distance_m = 1.2"))
    run(w, STOP, 200)
    _, x, y = w.human_positions()[0]
    assert math.hypot(3.0 - x, 2.5 - y) == pytest.approx(1.2, abs=1e-6)
    assert not w.last_report.contacts


def test_a_human_who_leaves_walks_to_the_exit_and_is_gone():
    w = world(APPROACHING_CHILD.replace('"approach", distance_m = 0.5', '"leave"'))
    reports = [w.step(STOP, tick=tick) for tick in range(100)]
    assert [r.tick for r in reports if r.left] == [49]  # 1 m at 1 m/s: the 50th step
    assert w.human_positions() == []
    assert w.state(tick=99, time_ms=1980).humans == ()
    w.apply_event(BehaviourEvent(at_s=2.0, human="kid", segment=Stand()))
    w.step(STOP, tick=100)
    assert [h[0] for h in w.human_positions()] == ["kid"]


def test_robot_led_and_audio_are_kept_as_state():
    w = world()
    w.step(ActuatorOutputs(led=(0.0, 0.0, 1.0), audio="song.mp3"), tick=0)
    state = w.state(tick=0, time_ms=0)
    assert state.led == (0.0, 0.0, 1.0)
    assert state.audio == "song.mp3"


WANDERERS = """
[world]
objects = [{ id = "ball", x_m = 3.0, y_m = 1.0 }]
[[humans]]
id = "kid"
x_m = 1.0
y_m = 1.0
behaviour = [{ kind = "wander", speed_mps = 0.9, pause_s = 0.3 }]
[[humans]]
id = "therapist"
role = "therapist"
x_m = 5.0
y_m = 4.0
behaviour = [{ kind = "follow", distance_m = 1.0 }]
"""


def states(seed: int, ticks: int = 400) -> list[bytes]:
    w = world(WANDERERS, seed=seed)
    out = []
    for tick in range(ticks):
        command = ActuatorOutputs(v_x=0.3, v_theta=0.4 if tick % 100 < 50 else -0.4)
        w.step(command, tick=tick)
        out.append(encode(w.state(tick=tick, time_ms=tick * 20)))
    return out


def test_same_scenario_and_seed_give_identical_encoded_states():
    assert states(7) == states(7)


def test_a_different_seed_gives_a_different_wander():
    first, second = states(7, 100), states(8, 100)
    kid = [msgspec.json.decode(s)["humans"][0] for s in (first[-1], second[-1])]
    assert (kid[0]["x_m"], kid[0]["y_m"]) != (kid[1]["x_m"], kid[1]["y_m"])


def test_wandering_humans_stay_inside_the_arena():
    w = world(WANDERERS, seed=3)
    for tick in range(1000):
        w.step(STOP, tick=tick)
        for _, x, y in w.human_positions():
            assert 0.25 - 1e-9 <= x <= 6.0 - 0.25 + 1e-9
            assert 0.25 - 1e-9 <= y <= 5.0 - 0.25 + 1e-9


def test_waypoints_are_walked_in_order_at_the_given_speed():
    w = world(
        "[[humans]]\nid = 'kid'\nx_m = 1.0\ny_m = 1.0\n"
        "behaviour = [{ kind = 'waypoints', waypoints = [[2.0, 1.0], [2.0, 2.0]],"
        " speed_mps = 0.5 },"
        " { at_s = 10.0, kind = 'waypoints', waypoints = [[1.0, 1.0]] }]\n"
    )
    run(w, STOP, 50)  # 1 s at 0.5 m/s times the seeded pace (scenarios.simulation.humans.PACE)
    x, y = w.human_positions()[0][1:]
    assert 1.0 + 0.5 * PACE[0] - 1e-6 <= x <= 1.0 + 0.5 * PACE[1] + 1e-6 and y == 1.0
    run(w, STOP, 60, 50)  # 2.2 s: the first corner is behind
    assert w.human_positions()[0][1] > 1.0
    run(w, STOP, 150, 100)  # 5 s: end of the path, standing
    assert w.human_positions()[0][1:] == pytest.approx((2.0, 2.0))
    run(w, STOP, 400, 250)  # the segment at 10 s walks back
    assert w.human_positions()[0][1:] == pytest.approx((1.0, 1.0))


def test_each_human_body_moves_at_the_velocity_its_driver_asked_for_every_tick():
    # the world sets a human's velocity only when it changed: standing, pausing, leaving
    # and coming back must never leave a stale one on the body
    timeline = '{ at_s = 2.0, kind = "stand" }, { at_s = 4.0, kind = "leave" }]'
    w = world(WANDERERS.replace("pause_s = 0.3 }]", f"pause_s = 0.3 }}, {timeline}"), seed=5)
    asked: dict[str, tuple[float, float]] = {}

    class Spy:
        """A human's driver, what its ``velocity`` answers noted (the rest passed through)."""

        def __init__(self, driver: HumanDriver, who: str) -> None:
            self.driver, self.who = driver, who

        def __getattr__(self, name: str) -> object:
            return getattr(self.driver, name)

        def velocity(self, *args: object) -> tuple[float, float]:
            asked[self.who] = velocity = self.driver.velocity(*args)
            return velocity

    for human in w.humans:
        human.driver = Spy(human.driver, human.spec.id)
    kinds_seen = set()
    for tick in range(600):
        if tick == 450:
            w.apply_event(BehaviourEvent(at_s=9.0, human="kid", segment=Stand()))
        w.step(STOP, tick=tick)
        for human in w.humans:
            kinds_seen.add((type(human.driver.segment).__name__, human.present))
            vx, vy = asked[human.spec.id]  # (one who left keeps still, asking for nothing)
            body = human.body.velocity
            assert (math.copysign(1, body.x), body.x) == (math.copysign(1, vx), vx)
            assert (math.copysign(1, body.y), body.y) == (math.copysign(1, vy), vy)
    assert {("Wander", True), ("Stand", True), ("Leave", False)} <= kinds_seen


def _reference_state(w: World, tick: int) -> WorldState:
    """``/world/state`` read through pymunk's own properties and rounded with ``round``
    (the rule the world's cached, fast path must reproduce to the bit)."""

    def cut(speed: float) -> float:
        return math.trunc(speed * 10**STATE_DECIMALS) / 10**STATE_DECIMALS

    def rigid(ident: str, kind: str, body: pymunk.Body, radius_m: float) -> BodyState:
        return BodyState(
            id=ident,
            kind=kind,
            x_m=round(body.position.x, STATE_DECIMALS),
            y_m=round(body.position.y, STATE_DECIMALS),
            theta_rad=round(wrap_angle(body.angle), STATE_DECIMALS),
            vx_mps=cut(body.velocity.x),
            vy_mps=cut(body.velocity.y),
            omega_radps=cut(body.angular_velocity),
            radius_m=radius_m,
        )

    humans = tuple(
        BodyState(
            id=h.spec.id,
            kind=str(h.spec.role),
            x_m=round(h.body.position.x, STATE_DECIMALS),
            y_m=round(h.body.position.y, STATE_DECIMALS),
            theta_rad=round(h.driver.heading_rad, STATE_DECIMALS),
            vx_mps=cut(h.body.velocity.x),
            vy_mps=cut(h.body.velocity.y),
            radius_m=h.spec.radius_m,
        )
        for h in w.humans
        if h.present
    )
    return WorldState(
        tick=tick,
        time_ms=tick * 20,
        robot=rigid("robot", "robot", w.robot, w.scenario.robot.radius_m),
        humans=humans,
        objects=tuple(rigid(t.spec.id, t.spec.category, t.body, t.spec.radius_m) for t in w.things),
        led=w.led,
        audio=w.audio,
        contacts=w.last_report.contacts,
    )


def test_the_state_of_bodies_at_rest_is_reused_and_equals_a_fresh_reading_to_the_bit():
    # standing, pausing, leaving and coming back; a robot that stops and turns
    # (a standing human glances around: a new heading, the same motion)
    timeline = '{ at_s = 2.0, kind = "stand" }, { at_s = 4.0, kind = "leave" }]'
    text = WANDERERS.replace("pause_s = 0.3 }]", f"pause_s = 0.3 }}, {timeline}")
    w = world(text + "[[humans]]\nid = 'onlooker'\nx_m = 5.0\ny_m = 1.0\n", seed=5)
    reused = 0
    previous = None
    for tick in range(1000):
        if tick == 450:
            w.apply_event(BehaviourEvent(at_s=9.0, human="kid", segment=Stand()))
        turning = ActuatorOutputs(v_theta=0.5)  # only the angle and spin change
        command = ActuatorOutputs(v_x=0.3, v_theta=-0.2) if tick % 200 < 100 else turning
        w.step(command if tick < 800 else STOP, tick=tick)
        state = w.state(tick=tick, time_ms=tick * 20)
        assert encode(state) == encode(_reference_state(w, tick)), tick
        if previous is not None:
            reused += sum(a is b for a, b in zip(previous.humans, state.humans, strict=False))
        previous = state
    assert reused > 100  # the fast path was taken (a standing human, a still therapist)


def test_one_human_leaving_as_another_comes_back_keeps_each_body_its_own_motion():
    # the space's order of bodies changes without its count changing between two reads
    two = APPROACHING_CHILD.replace('"approach", distance_m = 0.5', '"leave"')
    two += '[[humans]]\nid = "sib"\nx_m = 0.5\ny_m = 2.5\nbehaviour = [{ kind = "leave" }]\n'
    w = world(two)
    for tick in range(70):
        if tick == 50:
            w.apply_event(BehaviourEvent(at_s=1.0, human="sib", segment=Stand()))
        report = w.step(ActuatorOutputs(v_x=0.2, v_theta=0.3), tick=tick)
        assert encode(w.state(tick=tick, time_ms=tick * 20)) == encode(_reference_state(w, tick))
        if tick == 49:
            assert report.left == ("kid",)
    assert [h[0] for h in w.human_positions()] == ["sib"]


@settings(derandomize=True, max_examples=2000, deadline=None)
@given(
    st.floats(allow_nan=True, allow_infinity=True) | st.floats(-20.0, 20.0),
    st.sampled_from([STATE_DECIMALS, 4, 0, 15]),
)
@example(0.0000005, 6)  # ties (as far as a double is one), both signs of zero, tiny negatives
@example(-0.0000025, 6)
@example(2.5e-6, 6)
@example(0.00015, 4)
@example(-0.0, 6)
@example(-1e-9, 6)
@example(1e-9, 4)
@example(1e11 / 1e6, 6)
@example(123456.0000005, 6)
@example(2.5, 0)
def test_fast_rounding_is_round_to_the_bit(value: float, decimals: int):
    expected = round(value, decimals)
    got = rounded(value, decimals)
    assert struct.pack("<d", got) == struct.pack("<d", expected)
