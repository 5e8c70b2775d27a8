"""The Map Producer (section 4.5): queues sensors' MapUpdates and applies them to the map.

``submit`` judges an update at once against tables 4.1/4.2 and queues it: ``R`` drops
the earlier pending updates of the same target and attribute, ``A`` appends. Applied, an
appendable value joins its register whatever its policy (stored history is never erased),
and a RobotStatus field is marked as set (``RobotStatus.setfields``).
``consume`` applies the pending updates, in order, at the simulated time ``now_ms``.
A rejected update leaves the map exactly as it was and yields a ``Rejection``.

A sonar's ``scantime`` and a camera's ``frametime`` (their heartbeats, not in the thesis's
tables) change neither map: they are noted in :attr:`MapProducer.beats` for the safety
supervisor.

Each update is applied to a second map too, :attr:`MapProducer.perceived`, which nothing
else writes: the map as the sensors alone made it. Rules, scripts and their functions
change the shared map freely (the thesis lets them); the safety supervisor reads the
perceived one, so that no rule can hide a person from it, move one away or make an old
reading look fresh. The shared map refuses an entity past ``max_entities`` of its class;
the perceived one makes room for it (:meth:`_Index.evict`), so that no flood of furniture
or of a tracker's lost tracks can keep a child out of the supervisor's sight.
"""

from __future__ import annotations

from typing import Final

import msgspec
from oimi.pipeline.messages import (
    MAP_LISTS,
    REGISTER_CAPACITY,
    Entity,
    MapUpdate,
    Message,
    Policy,
    State,
    WorldMap,
)
from oimi.pipeline.sense.script_names import check_script_root
from oimi.pipeline.sense.updates import (
    DecodedUpdate,
    EntityClass,
    MapUpdateError,
    ScriptVect,
    Storage,
    Target,
    decode_update,
)

MAX_ENTITIES: Final = 1024
"""Default number of entities a class (cameras, humans...) may hold in the map."""

_HEARD: Final = frozenset({"isonline", "poses"})
"""The attributes whose arrival :attr:`MapProducer.heard` notes."""
_LISTED: Final = {EntityClass(m.name): (m.field, m.struct) for m in MAP_LISTS}
"""Classes kept as lists in the map: the WorldMap field and the Struct to allocate."""
_REPLACE: Final = Policy.R
_NOTED: Final = Storage.NOTED
_UPDATEABLE: Final = Storage.UPDATEABLE
_ROBOT_STATUS: Final = EntityClass.ROBOT_STATUS
_SCRIPT: Final = EntityClass.SCRIPT
"""Looked up once: an enum's member read through its class takes ``EnumType``'s slow
``__getattr__`` path, and ``submit`` and ``consume`` use these for every update or map."""


class Rejection(Message):
    """An update the producer refused, and why (recorded on ``/log``)."""

    update: MapUpdate
    reason: str
    """What is wrong, starting with the target, e.g. ``Camera/1.isonline: policy A ...``."""

    def __str__(self) -> str:
        return f"update {self.update.seq}: {self.reason}"


class MapProducer:
    """Owns the pending updates and applies them to ``world_map`` (mutated in place).

    ``register_capacity`` bounds every appendable register (oldest dropped first);
    ``script_root`` is the folder every ``script_vect`` path must lie in (empty: any
    relative path); ``max_entities`` bounds each class's list of entities.
    """

    def __init__(
        self,
        world_map: WorldMap,
        *,
        register_capacity: int = REGISTER_CAPACITY,
        script_root: str = "activities",
        max_entities: int = MAX_ENTITIES,
    ):
        if register_capacity < 1:
            raise ValueError(f"register_capacity must be at least 1, got {register_capacity}")
        if max_entities < 0:
            raise ValueError(f"max_entities must be at least 0, got {max_entities}")
        self.world_map = world_map
        self.perceived = msgspec.convert(msgspec.to_builtins(world_map), WorldMap)
        """The map as the sensors alone made it (a copy of ``world_map`` at the start, then
        every update ``consume`` applies); nothing else writes it. Its entities and lists
        are its own; a value an update brings (a pose in a register) is shared with the
        other map, so a reader that must not be fooled reads the entities' own fields (the
        supervisor reads ``positionrho``, ``positiontheta``, ``positionchangetime``,
        ``isonline``, ``isfixed`` and whether ``poses`` is empty)."""
        self.register_capacity = register_capacity
        self.script_root = check_script_root(script_root)
        self.max_entities = max_entities
        self._pending: list[DecodedUpdate] = []
        self._pending_keys: set[tuple[EntityClass, str, str]] = set()
        """The keys of the pending updates (an ``R`` scans the queue only for one of them)."""
        self._changes_pending = False
        """Whether a pending update may change the map (one that is not a heartbeat)."""
        self.heard: dict[tuple[str, str], int] = {}
        """When each sensor's status (``isonline``) and each entity's reading (``poses``)
        was last applied, ms, by (class, id), for the entities the perceived map holds: a
        sensor whose status stops coming has a dead link, whatever it last said; a reading
        still coming but long taken is a sensor repeating itself (frozen) or lagging."""
        self.beats: dict[tuple[str, str], int] = {}
        """When each sensor the perceived map holds took its latest scan or frame, ms, by
        (class, id): a sonar's ``scantime``, a camera's ``frametime``, their heartbeats (not
        in the thesis's map, which they leave as it was: a sensor frozen while it saw
        nothing still says it is on, and only a time repeated old tells it from one that
        sees an empty room). A time is taken no later than when it first came: a sensor
        whose clock is ahead and that then froze would otherwise repeat a time that looks
        fresh once the session's clock catches up with it."""
        self._stamps: dict[tuple[str, str], int] = {}
        """Each heartbeat's latest time as the sensor sent it (a repeat changes nothing)."""

    # ---------------------------------------------------------------- queue

    def submit(self, update: MapUpdate) -> Rejection | None:
        """Queue ``update``; a Rejection if it is invalid whatever the map holds."""
        try:
            decoded = decode_update(update, script_root=self.script_root)
        except MapUpdateError as exc:
            return Rejection(update=update, reason=exc.message)
        key = decoded.key
        if update.policy is _REPLACE and key in self._pending_keys:
            self._pending = [p for p in self._pending if p.key != key]
        self._pending.append(decoded)
        self._pending_keys.add(key)
        if decoded.spec.storage is not _NOTED:
            self._changes_pending = True
        return None

    @property
    def pending(self) -> bool:
        """Whether updates wait to be consumed."""
        return bool(self._pending)

    @property
    def changes_pending(self) -> bool:
        """Whether updates that may change the map wait to be consumed (a heartbeat alone,
        noted for the supervisor, changes neither map)."""
        return self._changes_pending

    @property
    def pending_updates(self) -> tuple[MapUpdate, ...]:
        """The updates waiting to be consumed, in the order they will be applied."""
        return tuple(p.update for p in self._pending)

    # ---------------------------------------------------------------- apply

    def consume(self, now_ms: int) -> list[Rejection]:
        """Apply every pending update at simulated time ``now_ms``; the rejections, in order.

        Sets ``lastupdatetime`` to ``now_ms`` when at least one update was applied.
        Raises ValueError if ``now_ms`` is earlier than the last time updates were applied.
        """
        perceived = self.perceived
        if now_ms < perceived.lastupdatetime:
            raise ValueError(
                f"now_ms {now_ms} is earlier than the map's lastupdatetime"
                f" {perceived.lastupdatetime}"
            )
        pending, self._pending = self._pending, []
        changes, self._changes_pending = self._changes_pending, False
        self._pending_keys.clear()
        # its rejections are the other's, said below; its statuses applied are the ones heard
        self._apply_all(perceived, pending, now_ms, heard=self.heard)
        if not changes:  # heartbeats alone: noted above, nothing for the shared map
            return []
        return self._apply_all(self.world_map, pending, now_ms)

    def _apply_all(
        self,
        world: WorldMap,
        pending: list[DecodedUpdate],
        now_ms: int,
        *,
        heard: dict[tuple[str, str], int] | None = None,
    ) -> list[Rejection]:
        """Apply ``pending`` to ``world``; the updates it has no room for. ``heard`` notes
        each sensor status and reading applied at ``now_ms`` (an entity the map had no room
        for has none: ``heard`` stays as bounded as the map)."""
        index = _Index(world)
        rejections: list[Rejection] = []
        applied = False
        noted: list[DecodedUpdate] = []
        for decoded in pending:
            spec, target = decoded.spec, decoded.target
            if spec.storage is _NOTED:  # a heartbeat: noted, not the map's
                noted.append(decoded)
                continue
            owner = index.find(target)
            if owner is None:
                full = index.count(target.klass) >= self.max_entities
                if full and heard is not None:  # the perceived map: room for what is sensed
                    full = not index.evict(target.klass, heard)
                if full:
                    rejections.append(
                        Rejection(
                            update=decoded.update,
                            reason=(
                                f"{target}.{spec.name}: cannot allocate a new"
                                f" {target.klass}: the map already holds"
                                f" {self.max_entities} of them"
                            ),
                        )
                    )
                    continue
                owner = index.allocate(target, now_ms)
            self._apply(world, owner, decoded)
            applied = True
            if heard is not None and spec.name in _HEARD:
                heard[target.klass, target.id] = now_ms  # a str enum
        if applied:
            world.lastupdatetime = now_ms
        if heard is not None:  # the perceived map: its sensors' heartbeats, in any order
            for decoded in noted:
                target = decoded.target
                if index.find(target) is not None:
                    self._beat((target.klass, target.id), decoded.value, now_ms)  # type: ignore[arg-type]
        return rejections

    def _beat(self, key: tuple[str, str], stamp: int, now_ms: int) -> None:
        """Note a heartbeat's time, no later than ``now_ms`` when it is new (a repeated one
        keeps the time it had when it first came)."""
        if self._stamps.get(key) != stamp:
            self._stamps[key] = stamp
            self.beats[key] = min(stamp, now_ms)

    def _apply(self, world: WorldMap, owner: State, decoded: DecodedUpdate) -> None:
        spec, value = decoded.spec, decoded.value
        # (no isinstance: on a Struct class it asks the metaclass, a call for every update)
        if type(value) is ScriptVect:
            info = world.scriptinfo
            info.script_vect = list(value.paths)
            info.restart = value.restart
        elif spec.storage is _UPDATEABLE:
            setattr(owner, spec.name, value)
        else:
            # R and A alike are appended: R only dropped the pending updates (``submit``).
            field = spec.name
            register = [*getattr(owner, field), value]
            setattr(owner, field, register[-self.register_capacity :])
            for name in spec.mirrors:
                setattr(owner, name, getattr(value, name))
        if owner is world.robotstatus:
            world.robotstatus.mark_set(spec.name)


class _Index:
    """The map's entities by class and ID, for one ``consume`` (the map may change between)."""

    def __init__(self, world: WorldMap):
        self._world = world
        self._by_id: dict[EntityClass, dict[str, State]] = {
            _ROBOT_STATUS: {"": world.robotstatus},  # a singleton's Target.id is ""
            _SCRIPT: {"": world.scriptinfo},
        }
        for klass, (field, _) in _LISTED.items():
            ids: dict[str, State] = {}
            for entity in getattr(world, field):
                ids.setdefault(entity.id, entity)
            self._by_id[klass] = ids

    def find(self, target: Target) -> State | None:
        return self._by_id[target.klass].get(target.id)

    def count(self, klass: EntityClass) -> int:
        return len(getattr(self._world, _LISTED[klass][0]))

    def evict(self, klass: EntityClass, heard: dict[tuple[str, str], int]) -> bool:
        """Drop an entity of ``klass`` to make room for a new one: the one the safety
        supervisor needs least, furniture (a fixed obstacle) first, then the one heard from
        (or, never heard, made) longest ago (a tracker's long-lost track), and forget when
        it was heard. Sensors are never dropped (False)."""
        field, kind = _LISTED[klass]
        entities: list[Entity] = getattr(self._world, field)
        if not issubclass(kind, Entity) or not entities:
            return False
        at = min(
            range(len(entities)),
            key=lambda i: (
                not getattr(entities[i], "isfixed", False),
                heard.get((klass, entities[i].id), entities[i].creationtime),
            ),
        )
        victim = entities.pop(at)
        if self._by_id[klass].get(victim.id) is victim:
            del self._by_id[klass][victim.id]
            heard.pop((klass, victim.id), None)
        return True

    def allocate(self, target: Target, now_ms: int) -> State:
        field, kind = _LISTED[target.klass]
        if issubclass(kind, Entity):
            entity: State = kind(id=target.id, creationtime=now_ms)
        else:
            entity = kind(id=target.id)
        getattr(self._world, field).append(entity)
        self._by_id[target.klass][target.id] = entity
        return entity
