"""Property tests: no update sequence breaks the map; R/A match a reference; rejects are inert."""

from __future__ import annotations

import json

import msgspec
from hypothesis import given, settings
from hypothesis import strategies as st
from oimi.pipeline.messages import MapUpdate, Policy, WorldMap
from oimi.pipeline.sense import UPDATE_TABLE, EntityClass, MapProducer, Storage, map_invariants

CAPACITY = 3
IDS = ["1", "2", "3"]

nonneg = st.integers(min_value=0, max_value=10_000)
finite = st.floats(min_value=-10.0, max_value=10.0, allow_nan=False)
unit = st.floats(min_value=0.0, max_value=1.0)


def obj(**fields) -> st.SearchStrategy[str]:
    return st.fixed_dictionaries(fields).map(json.dumps)


VALID_PAYLOAD: dict[str, st.SearchStrategy[str]] = {
    "isonline": st.sampled_from(["s_true", "s_false"]),
    "isfixed": st.sampled_from(["s_true", "s_false"]),
    "istarget": st.sampled_from(["s_true", "s_false"]),
    "category": st.text(max_size=5),
    "audioin": st.text(max_size=5),
    "poses": obj(positionrho=st.floats(0.0, 5.0), positiontheta=finite, positionchangetime=nonneg),
    "tracking": obj(permanencetime=nonneg, appearanceon=nonneg),
    "touch": obj(touchtype=st.sampled_from("CHPST"), duration=nonneg, startingtime=nonneg),
    "led": obj(r=unit, g=unit, b=unit, frequency=nonneg, duration=nonneg, startingtime=nonneg),
    "audioout": obj(duration=nonneg, startingtime=nonneg, trackpath=st.just("t.ogg")),
    "speed": obj(
        xspeed=finite, yspeed=finite, thetaspeed=finite, duration=nonneg, startingtime=nonneg
    ),
    "goalreached": obj(goalid=st.just("g1"), timestamp=nonneg),
    "goalfailed": obj(goalid=st.just("g2"), timestamp=nonneg),
    "goalinterrupted": obj(goalid=st.just("g3"), timestamp=nonneg),
    "script_vect": obj(
        restart=st.sampled_from(["s_true", "s_false"]),
        update=st.lists(
            st.sampled_from(["activities/a.json", "activities/b/c.txt", "generator:dance"]),
            max_size=3,
        ),
    ),
}
INT_ATTRS = {
    "width",
    "height",
    "fps",
    "scanfrequency",
    "scantime",
    "frametime",
    "batterytimeleft",
    "elapsedtime",
    "startingtime",
    "submove",
    "subled",
    "subaout",
}


def valid_payload(attr: str) -> st.SearchStrategy[str]:
    if attr in INT_ATTRS:
        return nonneg.map(str)
    return VALID_PAYLOAD[attr]


@st.composite
def valid_update(draw, classes=tuple(EntityClass), attrs=None, ids=IDS) -> MapUpdate:
    klass = draw(st.sampled_from(classes))
    names = sorted(a for a in UPDATE_TABLE[klass] if attrs is None or a in attrs)
    attr = draw(st.sampled_from(names))
    spec = UPDATE_TABLE[klass][attr]
    sep = draw(st.sampled_from(["/", "\\"]))
    objectid = f"{klass}{sep}{draw(st.sampled_from(ids))}"
    return MapUpdate(
        objectid=objectid,
        attributename=attr,
        policy=draw(st.sampled_from(spec.policies)),
        jsonmsg=draw(valid_payload(attr)),
    )


@st.composite
def corrupted_update(draw) -> MapUpdate:
    good = draw(valid_update())
    how = draw(st.sampled_from(["class", "attr", "policy", "json", "text", "path", "id"]))
    match how:
        case "class":
            return msgspec.structs.replace(good, objectid="Robot/1")
        case "attr":
            return msgspec.structs.replace(good, attributename=draw(st.text(max_size=6)))
        case "policy":
            return msgspec.structs.replace(
                good,
                policy=Policy.A,
                attributename="isonline",
                objectid="Camera/1",
                jsonmsg="s_true",
            )
        case "json":
            return msgspec.structs.replace(good, jsonmsg=good.jsonmsg + '"')
        case "text":
            return msgspec.structs.replace(good, jsonmsg=draw(st.text(max_size=8)))
        case "path":
            bad = draw(
                st.sampled_from(
                    [
                        "../x",
                        "/abs",
                        "",
                        "activities\\x",
                        "a/./b",
                        "x/y",
                        "generator:",
                        "generator:a/b",
                    ]
                )
            )
            return MapUpdate(
                objectid="Script",
                attributename="script_vect",
                policy=Policy.R,
                jsonmsg=json.dumps({"restart": "s_true", "update": [bad]}),
            )
        case _:
            return msgspec.structs.replace(good, objectid="Human/a b")


# a few hot keys make registers overflow and R/A interleave on the same target
hot_update = valid_update(
    classes=(EntityClass.HUMAN, EntityClass.ROBOT_STATUS), attrs=("poses", "audioin"), ids=["1"]
)
any_update = st.one_of(valid_update(), corrupted_update(), hot_update)
# a step: an update to submit, or None to consume
steps = st.lists(st.one_of(any_update, st.none()), max_size=40)


def numbered(items):
    seq = 0
    for item in items:
        if item is None:
            yield None
        else:
            seq += 1
            yield msgspec.structs.replace(item, seq=seq)


def fixed_fields(world: WorldMap) -> dict[str, list[tuple[str, int]]]:
    return {
        field: [(e.id, e.creationtime) for e in getattr(world, field)]
        for field in ("humans", "obstacles", "objects")
    } | {field: [(e.id, 0) for e in getattr(world, field)] for field in ("cameras", "sonars")}


@settings(max_examples=80, deadline=None)
@given(steps)
def test_no_update_sequence_breaks_the_map_invariants(sequence):
    world = WorldMap()
    producer = MapProducer(world, register_capacity=CAPACITY, max_entities=4)
    now = 0
    for step in [*numbered(sequence), None]:
        if step is not None:
            producer.submit(step)
            continue
        before = fixed_fields(world)
        now += 10
        producer.consume(now)
        after = fixed_fields(world)
        for field, entities in before.items():
            assert after[field][: len(entities)] == entities  # fixed fields, creation order
        assert map_invariants(world, register_capacity=CAPACITY) == []


APPENDABLE = [
    (klass, attr)
    for klass, attrs in UPDATE_TABLE.items()
    for attr, spec in attrs.items()
    if spec.storage is Storage.APPENDABLE
]


def register_of(world: WorldMap, klass: EntityClass, ident: str, attr: str) -> list:
    if klass is EntityClass.ROBOT_STATUS:
        return getattr(world.robotstatus, attr)
    field = {
        EntityClass.HUMAN: "humans",
        EntityClass.OBSTACLE: "obstacles",
        EntityClass.OBJECT: "objects",
    }[klass]
    for entity in getattr(world, field):
        if entity.id == ident:
            return getattr(entity, attr)
    return []


@settings(max_examples=80, deadline=None)
@given(
    st.lists(
        st.one_of(
            hot_update,
            hot_update,
            valid_update(
                classes=(EntityClass.HUMAN, EntityClass.OBJECT, EntityClass.ROBOT_STATUS),
                attrs=("poses", "tracking", "audioin", "touch"),
                ids=["1", "2"],
            ),
            st.none(),
        ),
        max_size=40,
    )
)
def test_registers_keep_history_and_r_drops_only_the_pending_updates(sequence):
    """Thesis 4.1: append-able fields: "all incoming updates will be stored in a circular
    register"; 4.5: "R deletes all non-already-processed updates that were issued before it"."""
    world = WorldMap()
    producer = MapProducer(world, register_capacity=CAPACITY)
    stored: dict[tuple[EntityClass, str, str], list[str]] = {}
    pending_model: list[MapUpdate] = []
    now = 0
    for step in [*numbered(sequence), None]:
        if step is not None:
            assert producer.submit(step) is None
            if step.policy is Policy.R:
                pending_model = [u for u in pending_model if not same_key(u, step)]
            pending_model.append(step)
            assert producer.pending_updates == tuple(pending_model)
            continue
        now += 10
        assert producer.consume(now) == []
        for update in pending_model:
            klass, _, ident = update.objectid.replace("\\", "/").partition("/")
            ident = "" if klass == "RobotStatus" else ident
            key = (EntityClass(klass), ident, update.attributename)
            stored[key] = [*stored.get(key, []), update.jsonmsg][-CAPACITY:]
        pending_model = []
        for (klass, ident, attr), expected in stored.items():
            stored_items = register_of(world, klass, ident, attr)
            assert [encode_item(attr, item) for item in stored_items] == [
                canonical(attr, text) for text in expected
            ]
        assert producer.perceived == world, "the safety supervisor's map: the same updates"


def same_key(a: MapUpdate, b: MapUpdate) -> bool:
    def key(u: MapUpdate):
        klass, _, ident = u.objectid.replace("\\", "/").partition("/")
        return klass, "" if klass == "RobotStatus" else ident, u.attributename

    return key(a) == key(b)


def encode_item(attr: str, item) -> object:
    return item if attr == "audioin" else msgspec.to_builtins(item)


def canonical(attr: str, text: str) -> object:
    return text if attr == "audioin" else json.loads(text)


@settings(max_examples=80, deadline=None)
@given(st.lists(any_update, max_size=20), st.integers(min_value=0, max_value=3))
def test_rejected_updates_never_change_the_encoded_map(batch, max_entities):
    batch = list(numbered(batch))
    start = WorldMap()
    warmup = MapProducer(start, register_capacity=CAPACITY)
    warmup.submit(
        MapUpdate(
            objectid="Human/1",
            attributename="poses",
            policy=Policy.A,
            jsonmsg='{"positionrho": 1, "positiontheta": 0, "positionchangetime": 0}',
        )
    )
    warmup.consume(5)
    snapshot = msgspec.json.encode(start)

    world = msgspec.json.decode(snapshot, type=WorldMap)
    producer = MapProducer(world, register_capacity=CAPACITY, max_entities=max_entities)
    rejected = {r.update.seq for u in batch if (r := producer.submit(u)) is not None}
    assert msgspec.json.encode(world) == snapshot  # submit never touches the map
    queued = producer.pending_updates  # what R left of the accepted ones
    assert all(u.seq not in rejected for u in queued)
    late = {r.update.seq for r in producer.consume(10)}

    clean = msgspec.json.decode(snapshot, type=WorldMap)
    reference = MapProducer(clean, register_capacity=CAPACITY, max_entities=max_entities)
    for update in queued:
        if update.seq not in late:
            assert reference.submit(update) is None
    if reference.pending:  # nothing accepted: the map must stay exactly the snapshot
        assert reference.consume(10) == []
    assert msgspec.json.encode(world) == msgspec.json.encode(clean)
