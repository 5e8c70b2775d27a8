"""What the Rerun view draws for people: colours from the one palette (the same as the web
console's), safety zones that light up, contact marks, people who leave and come back (the
texts: test_rerun_texts.py)."""

from __future__ import annotations

from pathlib import Path

import msgspec
import pytest
from oimi.pipeline.events import (
    MotionSource,
    SafetyIntervention,
    SafetyPhase,
    SafetyZone,
    Topic,
)
from oimi.recorder import palette
from oimi.recorder.rerun_sink import RerunSink, default_blueprint, zone_rings
from oimi.recorder.scene import SafetyZones
from recorder_synthetic import SCENE, rows, session, views, world_state


def packed(rgb: palette.RGB, alpha: int = 255) -> int:
    r, g, b = rgb
    return (r << 24) | (g << 16) | (b << 8) | alpha


@pytest.fixture(scope="module")
def rrd(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("view") / "s.rrd"
    with RerunSink(path, recording_id="s", scene=SCENE) as sink:
        for topic, time_ns, event in session(30):
            sink.record(topic, time_ns, event)
    return path


def test_each_body_has_its_palette_colour_in_the_room_and_in_the_plots(rrd: Path) -> None:
    child, therapist = palette.person_colour("child"), palette.person_colour("therapist")
    assert child != therapist
    for entity, rgb in [
        ("/world/humans/child1", child),
        ("/world/humans/therapist1", therapist),
        ("/world/robot", palette.colour("robot")),
    ]:
        [row] = rows(rrd, entity, static=True)
        assert row["Points2D:colors"] == [packed(rgb)], entity
    [plot] = rows(rrd, "/robot/distance/child1", static=True)
    assert plot["SeriesLines:colors"] == [packed(child)]
    assert plot["SeriesLines:names"] == ["child1"]
    [plot] = rows(rrd, "/robot/distance/therapist1", static=True)
    assert plot["SeriesLines:colors"] == [packed(therapist)]
    [trail] = rows(rrd, "/world/humans/child1/trail", static=True)
    assert trail["LineStrips2D:colors"][0] >> 8 == packed(child) >> 8


def test_the_web_console_uses_the_same_palette() -> None:
    """console.css carries the generated palette; console.js draws bodies only with it."""
    text = palette.CONSOLE_CSS.read_text(encoding="utf-8")
    assert palette.console_block(text) == palette.css()
    script = (palette.CONSOLE_CSS.parent / "console.js").read_text(encoding="utf-8")
    for name in ("robot", "robot-ink", "object", "obstacle"):
        assert f'paint("{name}")' in script
    assert "paint(personColour(h.kind, index))" in script
    assert "--oimi-${name}" in script


def test_people_of_one_kind_get_the_kinds_shades_in_order_then_cycle() -> None:
    names = [palette.person_colour_name("child", i) for i in range(4)]
    assert names == ["person-child", "person-child-2", "person-child-3", "person-child"]
    assert palette.person_colour_name("visitor", 0) == "person-other"
    assert len({palette.person_colour("child", i) for i in range(3)}) == 3


def test_the_robot_keeps_its_body_colour_and_the_led_goes_to_its_ring(rrd: Path) -> None:
    ring = [
        row for row in rows(rrd, "/world/robot/led", static=False) if "LineStrips2D:colors" in row
    ]
    assert ring
    colours = {c for row in ring for c in row["LineStrips2D:colors"]}
    assert colours <= {packed(palette.colour("led-off")), packed((0, 0, 255))}
    assert rows(rrd, "/world/robot", static=False)
    assert all("Points2D:colors" not in row for row in rows(rrd, "/world/robot", static=False))
    band = rows(rrd, "/robot/led", static=False)
    assert {c for row in band for c in row.get("SeriesPoints:colors") or []} == colours


def test_the_led_band_shows_a_white_led_and_one_axis_label() -> None:
    """On the plot's white a white LED vanished from the band: it is drawn on the robot's
    body colour, its axis from 0.5 to 1.5 (a label 0 sat on the first time label)."""
    [band] = [v for v in views(default_blueprint().root_container) if v.name == "LED colour"]
    background = band.properties["PlotBackground"].color.as_arrow_array().to_pylist()
    assert background == [packed(palette.colour("robot"))]
    assert band.properties["ScalarAxis"].range.as_arrow_array().to_pylist() == [[0.5, 1.5]]


def test_rings_are_drawn_when_their_look_changes_and_moved_with_their_body(
    tmp_path: Path,
) -> None:
    """A person's safety rings and the robot's LED ring: strips only when the radius,
    zone or colour changes; a transform at every sample puts them on the body."""
    path = tmp_path / "rings.rrd"
    with RerunSink(path, recording_id="r", scene=SCENE) as sink:
        for tick in range(30):
            state = msgspec.structs.replace(world_state(tick), led=(0.0, 0.0, 1.0))
            sink.record(Topic.WORLD_STATE, tick * 20_000_000, state)
    for entity, body in [
        ("/world/humans/child1/zones", "/world/humans/child1"),
        ("/world/robot/led", "/world/robot"),
    ]:
        found = rows(path, entity, static=False)
        strips = [row for row in found if "LineStrips2D:strips" in row]
        moves = [row for row in found if "Transform3D:translation" in row]
        placed = [row for row in rows(path, body, static=False) if "Points2D:positions" in row]
        assert len(strips) == 1 and len(moves) == len(placed) == 6
        moved = [xy for m in moves for xy in m["Transform3D:translation"][0][:2]]
        assert moved == pytest.approx([xy for p in placed for xy in p["Points2D:positions"][0]])


def test_zone_rings_surround_the_person_and_the_acting_one_is_bold() -> None:
    zones = SafetyZones(stop_m=0.15, slow_m=0.5)
    strips, colours, widths = zone_rings(0.25, zones, None)
    radii = [max(abs(x) for x, _ in strip) for strip in strips]
    assert radii == pytest.approx([0.75, 0.4])
    assert widths[0] == widths[1]
    _, bold_colours, bold_widths = zone_rings(0.25, zones, "stop")
    assert bold_widths[1] > bold_widths[0] == widths[0]
    assert bold_colours[1] == palette.colour("stop-zone") != colours[1]
    assert zones.acting(0.1) == "stop" and zones.acting(0.3) == "slow"
    assert zones.acting(0.6) is None


def test_contact_is_marked_in_the_room_and_logged_with_its_time(tmp_path: Path) -> None:
    path = tmp_path / "c.rrd"
    with RerunSink(path, recording_id="c", scene=SCENE) as sink:
        for tick in range(12):
            state = world_state(tick)
            if 3 <= tick < 8:
                state = msgspec.structs.replace(state, contacts=("child1",))
            sink.record(Topic.WORLD_STATE, tick * 20_000_000, state)
    marks = sorted(rows(path, "/world/contacts"), key=lambda row: row["tick"])
    assert [row["tick"] for row in marks] == [3, 5, 8]  # starts, each sample, ends
    assert marks[0]["Points2D:labels"] == ["contact"]
    assert marks[1]["Points2D:positions"] == [pytest.approx([2.025, -1.5])]  # robot-child midpoint
    assert "Clear:is_recursive" in marks[-1] and "Points2D:positions" not in marks[-1]
    texts = [row["TextLog:text"][0] for row in rows(path, "/log/safety")]
    assert texts == [
        "   0.06 s  contact: robot touches child1",
        "   0.16 s  contact with child1 ended",
    ]


def test_a_person_who_left_the_room_is_cleared_and_drawn_anew_on_return(tmp_path: Path) -> None:
    path = tmp_path / "left.rrd"
    with RerunSink(path, recording_id="left", scene=SCENE, world_every_n_ticks=1) as sink:
        for tick in range(12):
            gone = 3 <= tick < 6
            humans = ("therapist1",) if gone else ("child1", "therapist1")
            sink.record(Topic.WORLD_STATE, tick * 20_000_000, world_state(tick, humans=humans))

    def ticks(entity: str, column: str) -> list[int]:
        return sorted(row["tick"] for row in rows(path, entity, static=False) if row.get(column))

    drawn = ticks("/world/humans/child1", "Points2D:positions")
    assert drawn == [0, 1, 2, 6, 7, 8, 9, 10, 11]
    for entity in ("/world/humans/child1", "/robot/distance/child1"):
        assert ticks(entity, "Clear:is_recursive") == [3], entity
    assert ticks("/world/humans/therapist1", "Clear:is_recursive") == []
    said = sorted((row["tick"], row["TextLog:text"][0]) for row in rows(path, "/log/world"))
    assert said == [
        (3, "   0.06 s  child1 left the room"),
        (6, "   0.12 s  child1 came back into the room"),
    ]
    strips = [r for r in rows(path, "/world/humans/child1/trail") if r.get("LineStrips2D:strips")]
    last = max(strips, key=lambda row: row["tick"])  # a trail is drawn every 5th sample
    assert last["tick"] == 10
    assert len(last["LineStrips2D:strips"][0]) == 5, "the trail starts again at tick 6"


@pytest.mark.parametrize(
    ("led", "name"),
    [
        ((1.0, 1.0, 0.0), "yellow"),
        ((1.0, 0.5, 0.0), "orange"),
        ((0.0, 0.0, 1.0), "blue"),
        ((1.0, 1.0, 1.0), "white"),
        ((0.0, 0.0, 0.0), "off"),
        ((0.4, 0.2, 0.0), "dim orange"),
        ((0.5, 0.4, 0.1), "dim yellow"),  # half of (1, 0.8, 0.2), which is "yellow"
        ((1.0, 0.8, 0.2), "yellow"),
    ],
)
def test_led_colours_have_plain_names(led: tuple[float, float, float], name: str) -> None:
    assert palette.colour_name(led) == name


def test_the_zone_the_supervisor_reports_on_safety_is_the_one_drawn_bold(tmp_path: Path) -> None:
    """With ``/safety`` in the session, the bold ring is the zone the supervisor acted in
    (not one guessed from the geometry), and it goes thin again when the episode ends."""
    path = tmp_path / "z.rrd"
    far = SafetyZones(stop_m=0.01, slow_m=0.02)  # the geometry alone would light no ring
    with RerunSink(path, recording_id="z", scene=SCENE, zones=far, world_every_n_ticks=1) as sink:
        for tick in range(10):
            if tick in (2, 6):
                phase = SafetyPhase.START if tick == 2 else SafetyPhase.END
                sink.record(
                    Topic.SAFETY,
                    tick * 20_000_000,
                    SafetyIntervention(
                        tick=tick,
                        time_ms=tick * 20,
                        phase=phase,
                        source=MotionSource.SCRIPT,
                        zone=SafetyZone.STOP,
                        human="child1",
                    ),
                )
            sink.record(Topic.WORLD_STATE, tick * 20_000_000, world_state(tick))
    widths = {
        row["tick"]: row["LineStrips2D:radii"]
        for row in rows(path, "/world/humans/child1/zones", static=False)
        if "LineStrips2D:radii" in row
    }
    thin = pytest.approx([0.01, 0.01])
    assert sorted(widths) == [0, 2, 6], "drawn again only when the lit zone changes"
    assert widths[0] == thin
    assert widths[2][1] > widths[2][0]  # the stop ring, bold while the supervisor acts
    assert widths[6] == thin


def test_the_scene_carries_the_sessions_zones_to_the_view() -> None:
    from oimi.scenarios.schema import Scenario
    from oimi.scenarios.session.recording import scene_of

    scenario = msgspec.convert(
        {"name": "z", "robot": {"safety": {"stop_distance_m": 0.2, "slow_distance_m": 0.9}}},
        Scenario,
    )
    assert scene_of(scenario).safety == SafetyZones(stop_m=0.2, slow_m=0.9)


@pytest.mark.parametrize(
    ("exit_xy", "door"),
    [
        ((0.0, 2.5), ((0.0, 2.05), (0.0, 2.95))),  # the default: the left wall's middle
        ((6.0, 1.0), ((6.0, 0.55), (6.0, 1.45))),  # the right wall
        ((3.0, 5.0), ((2.55, 5.0), (3.45, 5.0))),  # the top
        ((0.2, 0.1), ((0.0, 0.0), (0.9, 0.0))),  # a corner: the nearer wall, kept on it
    ],
)
def test_the_door_is_drawn_on_the_wall_nearest_the_exit(exit_xy, door) -> None:
    """People who leave walk to the scenario's exit: the viewers draw a door there."""
    from oimi.recorder.scene import door_on_wall

    ends = door_on_wall(6.0, 5.0, exit_xy)
    assert [v for end in ends for v in end] == pytest.approx([v for end in door for v in end])


def test_the_session_report_draws_each_person_in_their_palette_colour() -> None:
    """The report's plots use the room view's colours: the first child is the palette's
    first child shade, the second the next one, the therapist the therapist's."""
    import polars as pl
    from oimi.analysis.plots import person_colours

    frame = pl.DataFrame(
        {
            "time_ms": [0, 0, 0, 0, 20],
            "id": ["robot", "c1", "t", "c2", "c1"],
            "kind": ["robot", "child", "therapist", "child", "child"],
        }
    )
    expected = {
        "c1": palette.person_colour("child", 0),
        "t": palette.person_colour("therapist", 0),
        "c2": palette.person_colour("child", 1),
    }
    assert person_colours(frame) == {k: palette.hex_colour(v) for k, v in expected.items()}
    assert expected["c1"] != expected["c2"]
