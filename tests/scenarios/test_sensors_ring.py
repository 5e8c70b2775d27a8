"""The simulated sonar ring's beams (``[sensors] sonar_beams``): each sonar reports the
nearest body its beam reaches, as a real ring does; the scenario field's validation, and
what the safety supervisor takes from it (``sonar_beam_rad``)."""

from __future__ import annotations

import math

import msgspec
import pytest
from oimi.pipeline.act.safety_config import ASSUMED
from oimi.pipeline.messages import ActuatorOutputs, MapUpdate
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import parse_scenario
from oimi.scenarios.real_robot import check_real_people
from oimi.scenarios.safety import supervisor_config
from oimi.scenarios.simulation.sensors import Sensors
from oimi.scenarios.simulation.world import World, stream_rng

STOP = ActuatorOutputs()


def room(beams: int, *people: tuple[float, float], extra: str = "") -> str:
    """The robot at (3, 2.5) facing +x, a ring of ``beams`` sonars, the people at their
    places (ids k0, k1...; each ``echo-N`` to the ring)."""
    lines = ['name = "ring"', "[robot]", "x_m = 3.0", "y_m = 2.5", "[sensors]"]
    lines += [f"sonar_beams = {beams}", extra]
    for n, (x, y) in enumerate(people):
        lines += ["[[humans]]", f'id = "k{n}"', f"x_m = {x}", f"y_m = {y}"]
    return "\n".join(lines) + "\n"


def echoes(text: str, seed: int = 1) -> dict[str, tuple[float, float]]:
    """The ring's echoes in its first scan, by obstacle id: (rho, theta)."""
    scenario = parse_scenario(text.encode()).scenario
    world = World(scenario, stream_rng(seed, "world"))
    sensors = Sensors(scenario.sensors, scenario, stream_rng(seed, "sensors"))
    world.step(STOP, tick=0)
    updates: list[MapUpdate] = sensors.sample(world, tick=0, time_ms=0)
    found = {}
    for u in updates:
        if u.objectid.startswith("Obstacle/") and u.attributename == "poses":
            pose = msgspec.json.decode(u.jsonmsg)
            found[u.objectid] = (pose["positionrho"], pose["positiontheta"])
    return found


def at(rho: float, bearing_deg: float) -> tuple[float, float]:
    """A place ``rho`` m from the robot at ``bearing_deg`` from its heading."""
    bearing = math.radians(bearing_deg)
    return (round(3.0 + rho * math.cos(bearing), 4), round(2.5 + rho * math.sin(bearing), 4))


def test_the_ideal_ring_reports_every_body_apart_at_its_centre() -> None:
    both = echoes(room(0, at(1.0, 0), at(2.0, 4)))
    assert both == {
        "Obstacle/echo-0": pytest.approx((1.0, 0.0)),
        "Obstacle/echo-1": pytest.approx((2.0, math.radians(4)), abs=1e-4),
    }


def test_two_children_in_one_beam_make_one_echo_the_nearers() -> None:
    """12 sonars, 30 degrees each: the one ahead reaches the child 1 m away first (their
    surface, 0.75 m); the one 2 m away, 4 degrees off, is in the same beam and no other:
    the ring does not report them (``make soak SEED=35``'s pair, on a real ring)."""
    assert echoes(room(12, at(1.0, 0), at(2.0, 4))) == {"Obstacle/echo-0": pytest.approx((0.75, 0))}
    assert echoes(room(12, at(2.0, 4), at(1.0, 0))) == {"Obstacle/echo-1": pytest.approx((0.75, 0))}


def entry(rho: float, off_deg: float, radius: float = 0.25) -> float:
    """Where a ray enters a disc ``rho`` m away, ``off_deg`` from the ray: the nearer root
    of ``t**2 - 2 t rho cos(off) + rho**2 - radius**2``."""
    along = rho * math.cos(math.radians(off_deg))
    return along - math.sqrt(along * along - rho * rho + radius * radius)


def test_a_sonar_reports_the_nearest_surface_in_its_beam_on_its_axis() -> None:
    """A real sonar gives a range, not a bearing. A child 1 m away, 10 degrees left: the
    sonar ahead reports their surface (0.75 m) on its axis, 10 degrees from them; their disc
    (14.5 degrees each side) reaches 5 degrees into the next beam (15 to 45 degrees), which
    reports where its edge enters the disc, on its axis (30 degrees). The ideal ring
    reports their centre."""
    assert echoes(room(12, at(1.0, 10))) == {
        "Obstacle/echo-0": pytest.approx((0.75, 0.0), abs=1e-4),
        "Obstacle/echo-0.s1": pytest.approx((entry(1.0, 5), math.radians(30)), abs=1e-4),
    }
    assert echoes(room(0, at(1.0, 10))) == {
        "Obstacle/echo-0": pytest.approx((1.0, math.radians(10)), abs=1e-4)
    }


def test_a_child_across_two_beams_makes_two_echoes_on_their_axes() -> None:
    """0.7 m away at 14 degrees, a child's disc (0.25 m: 21 degrees each side) reaches the
    sonar ahead and the next (30 degrees): two echoes, the second named for its sonar, each
    at the nearest surface in its beam (the disc's own nearest point ahead; where the beam's
    edge, 1 degree off the centre, enters it in the next)."""
    two = echoes(room(12, at(0.7, 14)))
    assert two == {
        "Obstacle/echo-0": pytest.approx((0.45, 0.0), abs=1e-4),
        "Obstacle/echo-0.s1": pytest.approx((entry(0.7, 1), math.radians(30)), abs=1e-4),
    }


def test_a_ring_reports_a_surface_within_its_range() -> None:
    """A ring reaching 1 m: a child 1.1 m away (their surface at 0.85 m) is heard by a real
    ring, not by the ideal one (centre to centre)."""
    near = "sonar_range_m = 1.0"
    assert echoes(room(12, at(1.1, 0), extra=near)) == {"Obstacle/echo-0": pytest.approx((0.85, 0))}
    assert echoes(room(0, at(1.1, 0), extra=near)) == {}


def test_a_child_behind_a_nearer_one_in_every_beam_they_reach_is_not_reported() -> None:
    """Occlusion: no echo logic can find them (docs/actuator-and-joystick.md)."""
    assert set(echoes(room(12, at(1.0, 0), at(2.5, 2)))) == {"Obstacle/echo-0"}
    assert set(echoes(room(0, at(1.0, 0), at(2.5, 2)))) == {"Obstacle/echo-0", "Obstacle/echo-1"}


def test_furniture_hides_a_child_behind_it_and_is_reported_once_fixed() -> None:
    """Furniture is a point at its centre, reported by the sonar whose beam holds it, on its
    axis: the supervisor never limits it, so all it does to the ring is hide what lies
    farther in that beam."""
    shelf = '[[world.obstacles]]\nid = "shelf"\nx_m = 3.0\ny_m = 3.5\nradius_m = 0.2\n'
    text = room(12, at(2.0, 90)) + shelf
    assert echoes(text) == {"Obstacle/shelf": pytest.approx((1.0, math.pi / 2), abs=1e-4)}
    aside = echoes(room(12, at(2.0, 80)) + shelf)  # hidden from the sonar at 90 degrees,
    assert set(aside) == {"Obstacle/shelf", "Obstacle/echo-0.s2"}  # not from the one at 60
    off = '[[world.obstacles]]\nid = "shelf"\nx_m = 3.1736\ny_m = 3.4848\nradius_m = 0.2\n'
    assert echoes(room(12) + off) == {"Obstacle/shelf": pytest.approx((1.0, math.pi / 2), abs=1e-4)}


def test_a_beams_echo_id_is_never_an_obstacle_id() -> None:
    shelf = '[[world.obstacles]]\nid = "echo-0.s1"\nx_m = 1.0\ny_m = 1.0\nradius_m = 0.2\n'
    two = echoes(room(12, at(0.7, 14)) + shelf)
    assert {"Obstacle/echo-0_", "Obstacle/echo-0_.s1"} <= set(two)


def test_the_ring_is_deterministic_and_seeded() -> None:
    text = room(8, at(0.7, 14), at(1.5, 100), extra="noise_rho_m = 0.01")
    assert echoes(text, seed=3) == echoes(text, seed=3)
    assert echoes(text, seed=3) != echoes(text, seed=4)


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("-1", "sensors.sonar_beams: must be >= 0, got -1"),
        ("361", "sensors.sonar_beams: must be <= 360, got 361"),
        ("12.5", "sensors.sonar_beams: Expected `int`, got `float`"),
        ('"12"', "sensors.sonar_beams: Expected `int`, got `str`"),
    ],
)
def test_a_ring_of_no_whole_number_of_sonars_is_refused_at_its_place(value, message) -> None:
    text = f'name = "x"\n[sensors]\nsonar_range_m = 3.0\nsonar_beams = {value}\n'
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(text.encode(), source="s.toml")
    assert str(caught.value).startswith(f"s.toml:4:1: {message}")


def test_the_supervisor_takes_a_sonars_beam_from_the_ring() -> None:
    ring = parse_scenario(b'name = "x"\n[sensors]\nsonar_beams = 12\n').scenario
    assert supervisor_config(ring).sonar_beam_rad == pytest.approx(math.pi / 6)
    ideal = parse_scenario(b'name = "x"\n').scenario
    assert supervisor_config(ideal).sonar_beam_rad == 0.0
    wider = b'name = "x"\n[sensors]\nsonar_beams = 12\n[robot.safety]\nsonar_beam_rad = 1.0\n'
    assert supervisor_config(parse_scenario(wider).scenario).sonar_beam_rad == 1.0
    assert ASSUMED["sonar_beam_rad"] == pytest.approx(math.pi / 3)  # without a scenario


def test_a_beam_narrower_than_the_rings_is_refused() -> None:
    text = b'name = "x"\n[sensors]\nsonar_beams = 8\n[robot.safety]\nsonar_beam_rad = 0.5\n'
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(text, source="s.toml")
    assert str(caught.value).startswith(
        "s.toml:5:1: robot.safety.sonar_beam_rad (rad): 0.5 is narrower than a sonar's beam of"
        " the ring (0.7853981633974483 rad: sonar_beams 8)"
    )


def test_a_real_robot_is_refused_an_ideal_ring() -> None:
    """``oimi bridge``: a real ring merges; the ideal ring's rule would drop a child."""
    with pytest.raises(ScenarioError) as caught:
        check_real_people(parse_scenario(b'name = "x"\n[sensors]\nrate_hz = 10\n', source="s.toml"))
    assert str(caught.value).startswith("s.toml:2:1: sensors.sonar_beams: 0 is an ideal ring")
    check_real_people(parse_scenario(b'name = "x"\n[sensors]\nsonar_beams = 16\nfov_rad = 2.0\n'))
    view = b"[sensors]\nfov_rad = 2.0\n"  # (a real robot's camera: test_scenario_safety_section)
    check_real_people(parse_scenario(b'name = "x"\n[robot.safety]\nsonar_beam_rad = 1.0\n' + view))


def test_a_ring_that_may_report_each_child_in_every_beam_must_fit_the_map() -> None:
    people = "".join(f'[[humans]]\nid = "k{n}"\nx_m = 1.0\ny_m = 1.0\n' for n in range(3))
    shelf = '[[world.obstacles]]\nid = "{}"\nx_m = 5.0\ny_m = 4.0\nradius_m = 0.1\n'
    text = f'name = "x"\n[sensors]\nsonar_beams = 341\n{people}{shelf.format("a")}'
    parse_scenario(text.encode())  # 3 x 341 echoes and a shelf: 1024, the map's room
    with pytest.raises(ScenarioError, match="in each of its 341 beams, more than the map"):
        parse_scenario((text + shelf.format("b")).encode())


def test_a_ring_whose_echoes_are_arcs_must_reach_farther() -> None:
    """A drive across may close on an echo's arc by its way (a tick at 0.5 m/s and braking
    at 1 m/s2: 0.135 m) times ``2 sin(beam / 4)`` (0.26 with 12 sonars): the 1.625 m the
    ideal ring needs (test_scenario_safety_section.py) become 1.66 m."""
    text = 'name = "x"\n[sensors]\nsonar_beams = 12\nsonar_range_m = {}\n'
    (warning,) = parse_scenario(text.format(1.65).encode(), source="s.toml").warnings
    assert str(warning).startswith(
        "s.toml:4:1: sensors.sonar_range_m (m): the sonar ring reaches 1.65 m, less than the"
        " 1.66 m in which"
    )
    assert ", and 0.035 m it may close on an echo's arc (sonar_beam_rad)):" in str(warning)
    assert parse_scenario(text.format(1.67).encode()).warnings == ()
