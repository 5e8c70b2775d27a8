"""``/map`` as keyframes and deltas: what the loop publishes rebuilds exactly the map it had."""

from __future__ import annotations

import msgspec
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from oimi.pipeline.events import MapDelta
from oimi.pipeline.mapdeltas import SECTIONS, TABLES, MapDeltas, apply_delta
from oimi.pipeline.messages import (
    ActivityStatus,
    ActivityTracking,
    Camera,
    GoalEvent,
    Human,
    LedStatus,
    Object,
    Obstacle,
    Pose,
    RobotStatus,
    WorldMap,
)

ROWS = {"humans": Human, "obstacles": Obstacle, "objects": Object, "cameras": Camera}
IDS = st.sampled_from(["a", "b", "c"])
TABLES_ = st.sampled_from(["humans", "humans", "objects", "cameras"])

mutation = st.one_of(
    st.tuples(st.just("add"), TABLES_, IDS),
    st.tuples(st.just("add"), TABLES_, IDS),
    st.tuples(st.just("forget"), TABLES_, IDS),
    st.tuples(st.just("move"), st.sampled_from(["humans", "obstacles", "objects"]), IDS),
    st.tuples(st.just("pose"), st.just("humans"), IDS),
    st.tuples(st.just("seen"), st.sampled_from(["humans", "humans", "objects"]), IDS),
    st.tuples(st.just("attribute"), st.just("humans"), IDS),
    st.tuples(st.just("swap"), TABLES_, IDS),
    st.tuples(st.just("time"), st.just(""), IDS),
    st.tuples(st.just("variable"), st.just(""), IDS),
    st.tuples(st.just("goal"), st.just(""), IDS),
    st.tuples(st.just("battery"), st.just(""), IDS),
    st.tuples(st.just("led"), st.just(""), IDS),
    st.tuples(st.just("clear"), st.just(""), IDS),
    st.tuples(st.just("block"), st.just(""), IDS),
    st.tuples(st.just("publish"), st.just(""), IDS),
    st.tuples(st.just("publish"), st.just(""), IDS),
    st.tuples(st.just("fresh"), st.just(""), IDS),
)


def mutate(world: WorldMap, step: tuple[str, str, str], n: int) -> None:
    """One change of the map, as the producer, the reader or a rule might make it."""
    kind, table, ident = step
    rows = getattr(world, table) if table else []
    row = next((r for r in rows if r.id == ident), None)
    match kind:
        case "add" if row is None:
            cls = ROWS[table]
            rows.append(cls(id=ident) if cls is Camera else cls(id=ident, creationtime=n))
        case "forget" if row is not None:
            rows.remove(row)
        case "move" if row is not None:
            row.positionrho, row.positiontheta = n / 7, -n / 3
        case "pose" if row is not None:
            row.poses.append(Pose(positionrho=n / 5, positiontheta=0.5, positionchangetime=n))
            del row.poses[:-3]  # a circular register of 3
        case "seen" if row is not None:  # as the producer: a pose, copied onto the row
            seen = Pose(positionrho=n / 5, positiontheta=-0.5, positionchangetime=n)
            row.poses.append(seen)
            del row.poses[:-3]
            row.positionrho, row.positiontheta = seen.positionrho, seen.positiontheta
            row.positionchangetime = seen.positionchangetime
        case "attribute" if row is not None:
            row.attributes[ident] = str(n)
        case "swap" if len(rows) > 1:  # rows change order: only a keyframe can say it
            rows[0], rows[-1] = rows[-1], rows[0]
        case "time":
            world.lastupdatetime = n
        case "variable":
            world.variables.pop(ident, None) if n % 3 == 0 else world.variables.update({ident: "1"})
        case "goal":
            world.robotstatus.goalreached.append(GoalEvent(goalid=ident, timestamp=n))
        case "battery":
            world.robotstatus.batterytimeleft = n
        case "led":
            world.robotstatus.led.append(
                LedStatus(r=n / 9, g=0.0, b=0.0, frequency=0, duration=n, startingtime=n)
            )
            del world.robotstatus.led[:-3]  # a circular register of 3
        case "clear":
            world.robotstatus.goalreached.clear()
        case "block":
            world.scriptinfo.blockid = f"blk{n}"


PUBLISH = ("publish", "", "")
ADD_AB = [("add", "humans", "a"), ("add", "humans", "b"), ("add", "objects", "a"), PUBLISH]


@settings(derandomize=True, max_examples=300, deadline=None)
@example(steps=[*ADD_AB, ("swap", "humans", ""), PUBLISH], keyframe_ms=60_000)
@example(steps=[*ADD_AB, ("forget", "humans", "a"), ("add", "humans", "a")], keyframe_ms=60_000)
@example(steps=[*ADD_AB, ("forget", "objects", "a"), ("pose", "humans", "b")], keyframe_ms=60_000)
@example(  # a row's dict changed in place twice: the kept copy must not be the live dict
    steps=[*ADD_AB, ("attribute", "humans", "a"), PUBLISH, ("attribute", "humans", "a")],
    keyframe_ms=60_000,
)
@example(  # a pose copied onto the row, then poses that are not (format 9 leaves out repeats)
    steps=[
        *ADD_AB,
        *[("seen", "humans", "a"), PUBLISH] * 2,
        *[("pose", "humans", "a"), PUBLISH] * 2,
        *[("move", "humans", "a"), ("seen", "humans", "a"), ("move", "humans", "a"), PUBLISH],
    ],
    keyframe_ms=60_000,
)
@given(
    steps=st.lists(mutation, max_size=40),
    keyframe_ms=st.sampled_from([20, 100, 60_000]),
)
def test_keyframes_and_deltas_rebuild_the_map_the_loop_had_at_each_publish(
    steps: list[tuple[str, str, str]], keyframe_ms: int
) -> None:
    world = WorldMap()
    deltas = MapDeltas(keyframe_ms=keyframe_ms)
    rebuilt: WorldMap | None = None
    published = 0
    for n, step in enumerate([*steps, PUBLISH]):
        if step[0] == "fresh":  # the same map in new objects: nothing may rely on identity
            world = msgspec.json.decode(msgspec.json.encode(world), type=WorldMap)
            continue
        if step[0] != "publish":  # changed in place: the kept copies must not share it
            mutate(world, step, n)
            continue
        delta = deltas.after(world, tick=n, time_ms=n * 20)
        if delta is None:
            assert rebuilt is None or rebuilt == world, "no message only when nothing changed"
            continue
        published += 1
        recorded = msgspec.json.decode(msgspec.json.encode(delta), type=MapDelta)
        rebuilt = apply_delta(rebuilt, recorded)
        assert rebuilt == world
        assert msgspec.json.encode(rebuilt) == msgspec.json.encode(world)
        assert published > 1 or delta.keyframe, "the first message is a keyframe"


def test_a_delta_holds_only_the_changed_rows_and_sections_and_the_forgotten_ids() -> None:
    world = WorldMap(humans=[Human(id="a", creationtime=0), Human(id="b", creationtime=0)])
    deltas = MapDeltas(keyframe_ms=5000)
    first = deltas.after(world, tick=0, time_ms=0)
    assert first is not None and first.keyframe and len(first.humans) == 2
    assert deltas.after(world, tick=1, time_ms=20) is None
    world.humans[1].positionrho = 2.0
    world.humans.pop(0)
    world.lastupdatetime = 40
    delta = deltas.after(world, tick=2, time_ms=40)
    assert delta is not None and not delta.keyframe
    assert [bytes(h) for h in delta.humans] == [b'{"id":"b","positionrho":2.0}']
    assert delta.removed == ("Human/a",)
    assert bytes(delta.lastupdatetime) == b"40" and not delta.scriptinfo and not delta.robotstatus
    assert b'"scriptinfo"' not in msgspec.json.encode(delta), "unchanged sections are left out"
    assert apply_delta(apply_delta(None, first), delta) == world


def test_a_keyframe_comes_again_at_the_first_change_after_the_interval() -> None:
    world = WorldMap()
    deltas = MapDeltas(keyframe_ms=100)
    kinds = []
    for tick in range(12):
        world.lastupdatetime = tick if tick % 2 else world.lastupdatetime  # odd ticks change
        delta = deltas.after(world, tick=tick, time_ms=tick * 20)
        kinds.append(None if delta is None else delta.keyframe)
    assert kinds == [True, False, None, False, None, True, None, False, None, False, None, True]


def test_the_map_delta_has_a_field_for_every_part_of_the_map() -> None:
    assert set(SECTIONS) | set(TABLES) == set(WorldMap.__struct_fields__)
    assert set(WorldMap.__struct_fields__) < set(MapDelta.__struct_fields__)


def test_a_delta_without_a_keyframe_or_removing_an_unknown_row_is_refused() -> None:
    with pytest.raises(ValueError, match="no keyframe before it"):
        apply_delta(None, MapDelta(tick=3, time_ms=60, lastupdatetime=1))
    with pytest.raises(ValueError, match="removes 'Human/x'"):
        apply_delta(WorldMap(), MapDelta(tick=3, time_ms=60, removed=("Human/x",)))


def test_a_value_beyond_64_bits_is_recorded_and_rebuilt() -> None:
    world = WorldMap(humans=[Human(id="a", creationtime=0)])
    deltas = MapDeltas(keyframe_ms=5000)
    first = deltas.after(world, tick=0, time_ms=0)
    world.humans[0].appearanceon = 10**30  # a rule's arithmetic may go past int64
    delta = deltas.after(world, tick=1, time_ms=20)
    assert first is not None and delta is not None
    assert apply_delta(apply_delta(None, first), delta) == world


def test_a_value_of_the_wrong_type_is_recorded_as_it_is_not_a_crash() -> None:
    """An extension's rule may write an int where the map holds strings: the loop goes on
    and the delta holds what the map held (as format 1's snapshot did)."""
    world = WorldMap(humans=[Human(id="a", creationtime=0)])
    deltas = MapDeltas(keyframe_ms=5000)
    deltas.after(world, tick=0, time_ms=0)
    world.humans[0].attributes["count"] = 3  # type: ignore[assignment]
    delta = deltas.after(world, tick=1, time_ms=20)
    assert delta is not None and b'"attributes":{"count":3}' in msgspec.json.encode(delta)
    world.humans[0].attributes["count"] = 3  # type: ignore[assignment]
    assert deltas.after(world, tick=2, time_ms=40) is None, "kept as it was: no change"


def test_a_registers_readings_are_frozen_so_the_kept_copy_may_share_them() -> None:
    """The publisher's copy shares readings (poses, touches, ...) with the live map; that is
    safe only because no one can change a reading in place: a register changes by entries
    added and dropped, which the copy's own lists show."""
    pose = Pose(positionrho=1.0, positiontheta=0.0, positionchangetime=0)
    world = WorldMap(humans=[Human(id="a", creationtime=0, poses=[pose])])
    deltas = MapDeltas(keyframe_ms=5000)
    assert deltas.after(world, tick=0, time_ms=0) is not None
    with pytest.raises(AttributeError):
        world.humans[0].poses[0].positionrho = 2.0  # type: ignore[misc]
    world.humans[0].poses.append(Pose(positionrho=0.9, positiontheta=0.1, positionchangetime=20))
    delta = deltas.after(world, tick=1, time_ms=20)
    assert delta is not None and len(delta.humans) == 1
    world.robotstatus.goalreached.append(GoalEvent(goalid="g", timestamp=40))  # in place
    assert deltas.after(world, tick=2, time_ms=40) is not None
    assert deltas.after(world, tick=3, time_ms=60) is None


def test_an_activitys_status_changed_in_place_is_a_change() -> None:
    """The copy shares enum members (each its own copy) but not the mutable row holding one."""
    world = WorldMap(robotstatus=RobotStatus(activities=[ActivityTracking(activityname="a")]))
    deltas = MapDeltas(keyframe_ms=5000)
    first = deltas.after(world, tick=0, time_ms=0)
    assert first is not None
    world.robotstatus.activities[0].status = ActivityStatus.RUNNING  # in place
    delta = deltas.after(world, tick=1, time_ms=20)
    assert delta is not None and b'"status":"running"' in bytes(delta.robotstatus)
    assert apply_delta(apply_delta(None, first), delta) == world


def test_a_register_that_took_a_reading_is_written_as_the_reading_added_and_one_dropped() -> None:
    poses = [Pose(positionrho=n, positiontheta=0.0, positionchangetime=n) for n in range(16)]
    world = WorldMap(humans=[Human(id="a", creationtime=0, poses=poses)])
    deltas = MapDeltas(keyframe_ms=5000)
    first = deltas.after(world, tick=0, time_ms=0)
    assert first is not None
    world.humans[0].poses = [
        *poses[1:],
        Pose(positionrho=16, positiontheta=0.0, positionchangetime=16),
    ]
    world.humans[0].positionrho = 16.0
    delta = deltas.after(world, tick=1, time_ms=20)
    assert delta is not None and not delta.keyframe
    assert bytes(delta.humans[0]) == (  # positionrho and positiontheta: the pose's
        b'{"id":"a","poses":{"dropped":1,"added":'
        b'[{"positionrho":16,"positiontheta":0.0,"positionchangetime":16}]},'
        b'"positionchangetime":0}'
    )
    assert apply_delta(apply_delta(None, first), delta) == world


def test_a_register_that_took_two_readings_is_written_as_two_dropped_after_a_usual_one() -> None:
    """A register as long as before that did not take just one reading (the quick look for
    the usual change finds it did not) is compared with its kept copy as it was."""
    poses = [Pose(positionrho=n, positiontheta=0.0, positionchangetime=n) for n in range(4)]
    world = WorldMap(humans=[Human(id="a", creationtime=0, poses=poses[:3])])
    deltas = MapDeltas(keyframe_ms=5000)
    first = deltas.after(world, tick=0, time_ms=0)
    assert first is not None
    world.humans[0].poses = poses[1:]  # the usual change: one dropped, one taken
    usual = deltas.after(world, tick=1, time_ms=20)
    assert usual is not None
    taken = [Pose(positionrho=n, positiontheta=0.0, positionchangetime=n) for n in (4, 5)]
    world.humans[0].poses = [poses[3], *taken]
    delta = deltas.after(world, tick=2, time_ms=40)
    assert delta is not None and not delta.keyframe
    assert b'"poses":{"dropped":2,"added":[{"positionrho":4,' in bytes(delta.humans[0])
    assert apply_delta(apply_delta(apply_delta(None, first), usual), delta) == world


def test_a_register_of_one_that_took_a_reading_is_written_whole() -> None:
    """None of its readings is kept, so it is not one dropped and one added (the quick check
    for a full register's usual change must leave it to the search)."""
    old = Pose(positionrho=1.0, positiontheta=0.0, positionchangetime=0)
    world = WorldMap(humans=[Human(id="a", creationtime=0, poses=[old])])
    deltas = MapDeltas(keyframe_ms=5000)
    first = deltas.after(world, tick=0, time_ms=0)
    world.humans[0].poses = [Pose(positionrho=2.0, positiontheta=0.0, positionchangetime=20)]
    delta = deltas.after(world, tick=1, time_ms=20)
    assert first is not None and delta is not None
    assert bytes(delta.humans[0]) == (
        b'{"id":"a","poses":[{"positionrho":2.0,"positiontheta":0.0,"positionchangetime":20}]}'
    )
    assert apply_delta(apply_delta(None, first), delta) == world


def test_a_row_leaves_out_the_fields_its_newest_reading_repeats_and_old_formats_wrote_them() -> (
    None
):
    world = WorldMap(humans=[Human(id="a", creationtime=0)])
    deltas = MapDeltas(keyframe_ms=5000)
    first = deltas.after(world, tick=0, time_ms=0)
    seen = Pose(positionrho=1.5, positiontheta=0.25, positionchangetime=20)
    human = world.humans[0]
    human.poses.append(seen)
    human.positionrho, human.positiontheta, human.positionchangetime = 1.5, 0.25, 20
    human.attributes["mood"] = "happy"
    delta = deltas.after(world, tick=1, time_ms=20)
    assert first is not None and delta is not None
    assert bytes(delta.humans[0]) == (
        b'{"id":"a","positionrho":1.5,"positiontheta":0.25,"positionchangetime":20,'
        b'"poses":[{"positionrho":1.5,"positiontheta":0.25,"positionchangetime":20}],'
        b'"attributes":{"mood":"happy"}}'
    ), "a register that was empty is written whole: nothing left out"
    human.poses.append(Pose(positionrho=1.75, positiontheta=0.25, positionchangetime=40))
    human.positionrho, human.positionchangetime = 1.75, 40
    later = deltas.after(world, tick=2, time_ms=40)
    assert later is not None
    assert bytes(later.humans[0]) == (
        b'{"id":"a","poses":{"added":'
        b'[{"positionrho":1.75,"positiontheta":0.25,"positionchangetime":40}]}}'
    )
    before = apply_delta(apply_delta(None, first), delta)
    assert apply_delta(before, later) == world
    assert apply_delta(before, later, repeats=False).humans[0].positionrho == 1.5, (
        "format 8 and older wrote every changed field: one left out is unchanged"
    )


def test_a_changed_robot_status_is_written_as_its_change_not_whole() -> None:
    """Format 5: ``robotstatus`` (a second's clock, registers of 16) changes twice a second."""
    leds = [
        LedStatus(r=1.0, g=0.0, b=0.0, frequency=0, duration=1000, startingtime=n)
        for n in range(16)
    ]
    world = WorldMap(robotstatus=RobotStatus(batterytimeleft=9000, led=leds))
    deltas = MapDeltas(keyframe_ms=5000)
    first = deltas.after(world, tick=0, time_ms=0)
    assert first is not None and b'"startingtime":15' in bytes(first.robotstatus)
    world.robotstatus.batterytimeleft = 8000
    world.robotstatus.led = [
        *leds[1:],
        LedStatus(r=0.5, g=0.0, b=0.0, frequency=0, duration=1000, startingtime=16),
    ]
    delta = deltas.after(world, tick=1, time_ms=1000)
    assert delta is not None and not delta.keyframe
    assert bytes(delta.robotstatus) == (
        b'{"batterytimeleft":8000,"led":{"dropped":1,"added":[{"r":0.5,"g":0.0,"b":0.0,'
        b'"frequency":0,"duration":1000,"startingtime":16}]}}'
    )
    assert apply_delta(apply_delta(None, first), delta) == world


def test_a_change_dropping_more_readings_than_the_register_has_is_refused() -> None:
    world = WorldMap(humans=[Human(id="a", creationtime=0)])
    first = MapDeltas(keyframe_ms=5000).after(world, tick=0, time_ms=0)
    assert first is not None
    bad = MapDelta(
        tick=1, time_ms=20, humans=(msgspec.Raw(b'{"id":"a","poses":{"dropped":2,"added":[]}}'),)
    )
    with pytest.raises(ValueError, match="tick 1 drops 2 of the 0 items of Human/a's poses"):
        apply_delta(apply_delta(None, first), bad)


def test_a_section_change_dropping_more_readings_than_it_has_is_refused() -> None:
    first = MapDeltas(keyframe_ms=5000).after(WorldMap(), tick=0, time_ms=0)
    assert first is not None
    bad = MapDelta(tick=1, time_ms=20, robotstatus=msgspec.Raw(b'{"led":{"dropped":1,"added":[]}}'))
    with pytest.raises(ValueError, match="tick 1 drops 1 of the 0 items of RobotStatus's led"):
        apply_delta(apply_delta(None, first), bad)
