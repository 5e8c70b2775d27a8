"""The Map Producer: pending queue (R/A), allocation, storage, registers, rejections."""

from __future__ import annotations

import msgspec
import pytest
from oimi.pipeline.messages import (
    Camera,
    GoalEvent,
    Human,
    MapUpdate,
    Policy,
    Touch,
    Tracking,
    WorldMap,
)
from oimi.pipeline.sense import MapProducer, Rejection, map_invariants


def pose(rho: float, t: int = 0) -> str:
    return f'{{"positionrho": {rho}, "positiontheta": 0.5, "positionchangetime": {t}}}'


def upd(objectid: str, attr: str, jsonmsg: str, policy: Policy = Policy.R, seq: int = 0):
    return MapUpdate(objectid=objectid, attributename=attr, policy=policy, jsonmsg=jsonmsg, seq=seq)


def fresh(**kwargs) -> tuple[WorldMap, MapProducer]:
    world = WorldMap()
    return world, MapProducer(world, **kwargs)


def test_submit_rejects_at_once_and_queues_nothing():
    _, producer = fresh()
    rejection = producer.submit(upd("Camera/1", "isonline", "s_true", Policy.A, seq=42))
    assert rejection == Rejection(
        update=upd("Camera/1", "isonline", "s_true", Policy.A, seq=42),
        reason="Camera/1.isonline: policy A not allowed (allowed: R)",
    )
    assert str(rejection).startswith("update 42: Camera/1.isonline")
    assert not producer.pending


def test_r_drops_earlier_pending_updates_of_same_target_and_attribute():
    _, producer = fresh()
    producer.submit(upd("Human/1", "poses", pose(1), Policy.A, seq=1))
    producer.submit(
        upd("Human/1", "tracking", '{"permanencetime": 1, "appearanceon": 0}', Policy.A, seq=2)
    )
    producer.submit(upd("Human/2", "poses", pose(2), Policy.A, seq=3))
    producer.submit(upd("Human\\1", "poses", pose(3), Policy.R, seq=4))
    assert [u.seq for u in producer.pending_updates] == [2, 3, 4]


def test_a_keeps_earlier_pending_updates():
    _, producer = fresh()
    for seq in range(3):
        producer.submit(upd("Human/1", "poses", pose(seq), Policy.A, seq=seq))
    assert [u.seq for u in producer.pending_updates] == [0, 1, 2]


def test_r_on_a_singleton_drops_earlier_pending_whatever_its_id():
    _, producer = fresh()
    producer.submit(upd("RobotStatus/a", "batterytimeleft", "5", seq=1))
    producer.submit(upd("RobotStatus", "batterytimeleft", "6", seq=2))
    assert [u.seq for u in producer.pending_updates] == [2]


def test_consume_applies_in_order_and_empties_the_queue():
    world, producer = fresh()
    producer.submit(upd("Camera/1", "width", "640"))
    producer.submit(upd("Camera/1", "isonline", "s_true"))
    assert producer.consume(100) == []
    assert not producer.pending
    assert world.cameras == [Camera(id="1", isonline=True, width=640)]
    assert world.lastupdatetime == 100


def test_consume_without_updates_leaves_lastupdatetime():
    world, producer = fresh()
    assert producer.consume(100) == []
    assert world.lastupdatetime == 0


def test_consume_refuses_a_clock_going_backwards():
    _, producer = fresh()
    producer.submit(upd("Human/1", "poses", pose(1.0, 500)))
    producer.consume(500)
    with pytest.raises(ValueError, match="now_ms 400 is earlier than the map's lastupdatetime"):
        producer.consume(400)


def test_unknown_id_allocates_an_entity_with_creation_time_in_creation_order():
    world, producer = fresh()
    producer.submit(upd("Human/b", "poses", pose(1.0, 10)))
    producer.consume(100)
    producer.submit(upd("Human/a", "poses", pose(2.0, 20)))
    producer.submit(upd("Human/b", "poses", pose(3.0, 30), Policy.A))
    producer.consume(200)
    assert [(h.id, h.creationtime) for h in world.humans] == [("b", 100), ("a", 200)]
    assert [p.positionrho for p in world.humans[0].poses] == [1.0, 3.0]


def test_each_class_allocates_into_its_own_list():
    world, producer = fresh()
    producer.submit(upd("Camera/c", "fps", "30"))
    producer.submit(upd("Sonar/s", "scanfrequency", "10"))
    producer.submit(upd("Obstacle/o", "isfixed", "s_false"))
    producer.submit(upd("Object/x", "category", "ball"))
    producer.submit(upd("Object/y", "istarget", "s_true"))
    producer.consume(7)
    assert [c.fps for c in world.cameras] == [30]
    assert [s.scanfrequency for s in world.sonars] == [10]
    assert [(o.id, o.isfixed, o.creationtime) for o in world.obstacles] == [("o", False, 7)]
    assert [(o.id, o.category, o.istarget) for o in world.objects] == [
        ("x", "ball", False),
        ("y", "", True),
    ]


def test_pose_and_tracking_refresh_current_scalars():
    world, producer = fresh()
    producer.submit(upd("Human/1", "poses", pose(1.25, 90), Policy.A))
    producer.submit(upd("Human/1", "tracking", '{"permanencetime": 400, "appearanceon": 30}'))
    producer.consume(100)
    human = world.humans[0]
    assert (human.positionrho, human.positiontheta, human.positionchangetime) == (1.25, 0.5, 90)
    assert (human.permanencetime, human.appearanceon) == (400, 30)
    assert human.tracking == [Tracking(permanencetime=400, appearanceon=30)]


def test_fixed_fields_never_change_after_creation():
    world, producer = fresh()
    producer.submit(upd("Human/1", "poses", pose(1)))
    producer.consume(100)
    producer.submit(upd("Human/1", "poses", pose(2), Policy.A))
    producer.consume(300)
    assert (world.humans[0].id, world.humans[0].creationtime) == ("1", 100)


def test_register_drops_oldest_beyond_capacity():
    world, producer = fresh(register_capacity=3)
    for i in range(5):
        producer.submit(upd("Human/1", "poses", pose(float(i)), Policy.A))
    producer.consume(10)
    assert [p.positionrho for p in world.humans[0].poses] == [2.0, 3.0, 4.0]
    assert world.humans[0].positionrho == 4.0


def test_default_register_capacity_is_sixteen():
    world, producer = fresh()
    for i in range(20):
        producer.submit(upd("RobotStatus", "audioin", f"word{i}", Policy.A))
    producer.consume(10)
    assert world.robotstatus.audioin == [f"word{i}" for i in range(4, 20)]


def test_r_drops_pending_updates_and_is_appended_without_erasing_history():
    """Thesis 4.5: "R deletes all non-already-processed updates that were issued before it";
    4.1: append-able: "all incoming updates will be stored in a circular register"."""
    world, producer = fresh()
    producer.submit(upd("Human/1", "poses", pose(1), Policy.A))
    producer.consume(10)
    producer.submit(upd("Human/1", "poses", pose(9), Policy.A))
    producer.submit(upd("Human/1", "poses", pose(2), Policy.R))
    producer.submit(upd("Human/1", "poses", pose(3), Policy.A))
    producer.consume(20)
    assert [p.positionrho for p in world.humans[0].poses] == [1.0, 2.0, 3.0]
    assert world.humans[0].positionrho == 3.0


def caress():
    """A 200 ms caress at 50 ms, for the robot's touch register."""
    touch = '{"touchtype": "C", "duration": 200, "startingtime": 50}'
    return upd("RobotStatus", "touch", touch, Policy.A)


def test_the_map_records_which_robot_status_fields_were_ever_set():
    """Issue 16 ruling on thesis 4.1/4.5: an attribute never updated is unknown; the map
    records whether each RobotStatus field was ever set (RobotStatus "commits to memory ...
    the inputs received by the sensors")."""
    world, producer = fresh()
    assert world.robotstatus.setfields == []
    producer.submit(caress())
    producer.submit(upd("RobotStatus", "batterytimeleft", "0"))
    producer.submit(upd("RobotStatus", "batterytimeleft", "5"))
    producer.submit(upd("Human/1", "poses", pose(1), Policy.A))
    producer.consume(10)
    assert world.robotstatus.setfields == ["touch", "batterytimeleft"]
    assert producer.submit(upd("RobotStatus", "elapsedtime", "-1")) is not None
    producer.consume(20)
    assert world.robotstatus.setfields == ["touch", "batterytimeleft"]


def test_robot_status_registers_and_scalars():
    world, producer = fresh()
    producer.submit(caress())
    producer.submit(
        upd("RobotStatus/r", "goalreached", '{"goalid": "g", "timestamp": 60}', Policy.A)
    )
    producer.submit(upd("RobotStatus", "batterytimeleft", "1000"))
    producer.submit(upd("RobotStatus", "elapsedtime", "70"))
    producer.submit(upd("RobotStatus", "startingtime", "0"))
    producer.consume(80)
    status = world.robotstatus
    assert status.touch == [Touch(touchtype="C", duration=200, startingtime=50)]
    assert status.goalreached == [GoalEvent(goalid="g", timestamp=60)]
    assert (status.batterytimeleft, status.elapsedtime) == (1000, 70)


def test_script_updates_set_scriptinfo():
    world, producer = fresh()
    world.scriptinfo.script_vect = ["activities/old.json"]
    producer.submit(upd("Script", "submove", "2"))
    producer.submit(upd("Script", "subled", "1"))
    producer.submit(upd("Script/x", "subaout", "3"))
    producer.submit(
        upd(
            "Script",
            "script_vect",
            '{"restart": "s_true", "update": ["activities/a.json", "activities/b"]}',
        )
    )
    producer.consume(5)
    info = world.scriptinfo
    assert (info.submove, info.subled, info.subaout) == (2, 1, 3)
    assert info.script_vect == ["activities/a.json", "activities/b"]
    assert info.restart is True


def test_bad_script_vect_path_is_rejected_and_lifo_unchanged():
    world, producer = fresh()
    world.scriptinfo.script_vect = ["activities/old.json"]
    rejection = producer.submit(
        upd("Script", "script_vect", '{"restart": "s_true", "update": ["../evil.json"]}', seq=9)
    )
    assert rejection is not None
    assert rejection.reason == (
        "Script.script_vect: at `$.update[0]`: path '../evil.json' contains '..'"
    )
    assert producer.consume(5) == []
    assert world.scriptinfo.script_vect == ["activities/old.json"]


def test_entity_limit_rejects_at_consume_and_goes_on():
    world, producer = fresh(max_entities=1)
    producer.submit(upd("Human/1", "poses", pose(1), seq=1))
    producer.submit(upd("Human/2", "poses", pose(2), seq=2))
    producer.submit(upd("Camera/c", "fps", "5", seq=3))
    rejections = producer.consume(10)
    assert [r.update.seq for r in rejections] == [2]
    assert rejections[0].reason == (
        "Human/2.poses: cannot allocate a new Human: the map already holds 1 of them"
    )
    assert [h.id for h in world.humans] == ["1"]
    assert [c.fps for c in world.cameras] == [5]


def test_the_perceived_map_makes_room_for_a_new_person_past_the_limit():
    """A tracker that hands out new IDs fills the map with lost tracks; the shared map
    refuses the next (thesis 4.1: entities stay), but the safety supervisor's perceived map
    drops the track heard from longest ago, so a child who walks in is never out of its
    sight."""
    world, producer = fresh(max_entities=3)
    for n in range(3):
        producer.submit(upd(f"Human/track{n}", "poses", pose(2.0, t=n * 100)))
        producer.consume(n * 100)
    producer.submit(upd("Human/track1", "poses", pose(2.0, t=250)))
    producer.consume(250)  # track0 is now the one heard from longest ago
    producer.submit(upd("Human/child", "poses", pose(0.6, t=300)))
    assert [r.update.objectid for r in producer.consume(300)] == ["Human/child"]
    assert [h.id for h in world.humans] == ["track0", "track1", "track2"]
    perceived = producer.perceived
    assert [h.id for h in perceived.humans] == ["track1", "track2", "child"]
    assert ("Human", "track0") not in producer.heard
    assert producer.heard["Human", "child"] == 300


def test_the_perceived_map_drops_furniture_before_anything_that_moves():
    _, producer = fresh(max_entities=2)
    producer.submit(upd("Obstacle/echo", "isfixed", "s_false"))  # a body that moves
    producer.submit(upd("Obstacle/echo", "poses", pose(1.0)))
    producer.submit(upd("Obstacle/table", "poses", pose(2.0)))  # fixed unless told
    producer.consume(100)
    producer.submit(upd("Obstacle/echo2", "isfixed", "s_false"))
    producer.submit(upd("Obstacle/echo2", "poses", pose(1.5)))
    producer.consume(200)
    assert [o.id for o in producer.perceived.obstacles] == ["echo", "echo2"]


def test_all_rejected_at_consume_leaves_the_map_byte_identical():
    world, producer = fresh(max_entities=0)
    before = msgspec.json.encode(world)
    producer.submit(upd("Human/1", "poses", pose(1)))
    assert len(producer.consume(10)) == 1
    assert msgspec.json.encode(world) == before


def test_updates_reach_entities_already_in_the_map():
    world = WorldMap(humans=[Human(id="kid", creationtime=0)])
    producer = MapProducer(world)
    producer.submit(upd("Human/kid", "poses", pose(0.8)))
    producer.consume(10)
    assert len(world.humans) == 1
    assert world.humans[0].positionrho == 0.8
    assert world.humans[0].creationtime == 0


def test_constructor_checks_its_options():
    with pytest.raises(ValueError, match="register_capacity must be at least 1"):
        MapProducer(WorldMap(), register_capacity=0)
    with pytest.raises(ValueError, match=r"script_root: path '\.\./x' contains"):
        MapProducer(WorldMap(), script_root="../x")


def test_map_invariants_name_violations():
    world = WorldMap(
        lastupdatetime=100,
        humans=[Human(id="a", creationtime=50), Human(id="a", creationtime=200)],
        cameras=[Camera(id="")],
    )
    world.robotstatus.audioin = ["x"] * 3
    problems = map_invariants(world, register_capacity=2)
    assert "cameras[0]: empty id" in problems
    assert "humans[1]: duplicate id 'a'" in problems
    assert any("creationtime 200 is after the map's lastupdatetime 100" in p for p in problems)
    assert "robotstatus.audioin: 3 entries, capacity 2" in problems
    assert map_invariants(WorldMap()) == []


def test_a_map_recorded_before_setfields_decodes_with_every_field_unknown():
    """Schemas evolve by appending fields with defaults: an older /map still decodes."""
    old = msgspec.json.encode(WorldMap())
    old = old.replace(b',"setfields":[]', b"")
    assert b"setfields" not in old
    world = msgspec.json.decode(old, type=WorldMap)
    assert world.robotstatus.setfields == [] and not world.robotstatus.known("batterytimeleft")


def test_map_invariants_name_a_bad_setfields_list():
    world = WorldMap()
    world.robotstatus.setfields = ["touch", "touch", "wings"]
    problems = map_invariants(world)
    assert any("duplicate names" in p for p in problems)
    assert any("'wings' is not a RobotStatus field" in p for p in problems)


def test_the_perceived_map_holds_what_the_sensors_said_whatever_else_writes_the_map():
    world, producer = fresh()
    producer.submit(upd("Human/1", "poses", pose(1.5, 10), seq=1))
    producer.submit(upd("Camera/front", "isonline", "s_true", seq=2))
    producer.consume(20)
    assert producer.perceived == world and producer.perceived is not world
    world.humans.clear()  # a rule's body may drop, move or restamp people in the shared map
    world.cameras[0].isonline = False
    world.lastupdatetime = 10**9
    producer.submit(upd("Human/2", "poses", pose(2.5, 30), seq=3))
    producer.consume(40)  # the shared map's time does not stop the producer
    assert [(h.id, h.positionrho) for h in producer.perceived.humans] == [("1", 1.5), ("2", 2.5)]
    assert [h.id for h in world.humans] == ["2"]
    assert producer.perceived.cameras[0].isonline
    assert producer.perceived.lastupdatetime == world.lastupdatetime == 40


def test_the_perceived_map_starts_as_a_copy_of_the_map():
    world = WorldMap(humans=[Human(id="1", creationtime=0, positionrho=1.0)])
    producer = MapProducer(world)
    assert producer.perceived == world
    world.humans[0].positionrho = 9.0
    assert producer.perceived.humans[0].positionrho == 1.0


def test_heard_is_when_each_status_and_reading_last_arrived_whatever_it_said():
    _, producer = fresh()
    producer.submit(upd("Camera/front", "isonline", "s_true"))
    producer.submit(upd("Sonar/ring", "isonline", "s_false"))
    producer.consume(100)
    producer.submit(upd("Camera/front", "isonline", "s_true"))
    producer.submit(upd("Camera/front", "fps", "30"))  # not a status
    producer.submit(upd("Sonar/ring", "scanfrequency", "5"))
    producer.consume(1100)
    producer.submit(upd("Obstacle/echo", "poses", pose(1, t=300), Policy.A))  # taken at 300
    producer.submit(upd("Obstacle/echo", "isfixed", "s_false"))  # not a reading
    producer.submit(upd("Obstacle/shelf", "isfixed", "s_true"))
    producer.consume(1200)
    assert producer.heard == {
        ("Camera", "front"): 1100,
        ("Sonar", "ring"): 100,
        ("Obstacle", "echo"): 1200,  # when it arrived, not when it was taken
    }
    assert producer.perceived.sonars[0].isonline is False


def test_heard_keeps_only_the_sensors_the_map_has_room_for():
    _, producer = fresh(max_entities=2)
    for n in range(5):
        producer.submit(upd(f"Camera/{n}", "isonline", "s_true"))
    producer.consume(100)
    assert producer.heard == {("Camera", "0"): 100, ("Camera", "1"): 100}
    assert [c.id for c in producer.perceived.cameras] == ["0", "1"]


def test_a_heartbeat_is_noted_no_later_than_it_came_and_a_repeat_keeps_that_time():
    """A ring whose clock is 2 s ahead, then frozen (it repeats its last scan time): had the
    time been noted as sent, it would look fresh for half a second once the session's clock
    caught up with it, and the supervisor let the robot reverse into a child behind it."""
    _, producer = fresh()
    producer.submit(upd("Sonar/ring", "isonline", "s_true"))
    producer.consume(0)
    for now in (100, 200):  # scanning, its clock ahead: each new time counts as it comes
        producer.submit(upd("Sonar/ring", "scantime", str(now + 2000)))
        producer.consume(now)
        assert producer.beats == {("Sonar", "ring"): now}
    for now in (300, 2200, 2400):  # frozen: its last time again and again
        producer.submit(upd("Sonar/ring", "scantime", "2200"))
        producer.consume(now)
        assert producer.beats == {("Sonar", "ring"): 200}


def test_a_rings_scan_time_is_noted_for_the_supervisor_and_leaves_both_maps_alone():
    """The ring's heartbeat is not the thesis's map: neither map changes (no rule runs for
    it), and only a sonar the perceived map holds is noted (a flood of ids grows nothing)."""
    world, producer = fresh()
    producer.submit(upd("Sonar/ring", "scantime", "80"))
    assert not producer.changes_pending
    producer.submit(upd("Sonar/ring", "isonline", "s_true"))
    assert producer.changes_pending
    producer.submit(upd("Sonar/other", "scantime", "90"))  # no such sonar: not noted
    producer.consume(100)
    assert producer.beats == {("Sonar", "ring"): 80}
    shared, perceived = msgspec.to_builtins(world), msgspec.to_builtins(producer.perceived)
    producer.submit(upd("Sonar/ring", "scantime", "150"))
    producer.submit(upd("Sonar/ring", "scantime", "200"))  # R: the latest of a tick
    assert producer.pending and not producer.changes_pending  # the loop need run no rule
    assert producer.consume(200) == []
    assert producer.beats == {("Sonar", "ring"): 200}
    assert msgspec.to_builtins(world) == shared
    assert msgspec.to_builtins(producer.perceived) == perceived
    assert [s.id for s in world.sonars] == ["ring"]
