"""What must hold of a world map whatever updates it received (used by property tests)."""

from __future__ import annotations

from oimi.pipeline.messages import ENTITY_LISTS, MAP_LISTS, REGISTER_CAPACITY, WorldMap

_ENTITY_LISTS = tuple(m.field for m in ENTITY_LISTS)
_DEVICE_LISTS = tuple(m.field for m in MAP_LISTS if not m.entity)
_ENTITY_REGISTERS = ("poses", "tracking")
_ROBOT_REGISTERS = (
    "touch",
    "led",
    "audioout",
    "audioin",
    "speed",
    "goalreached",
    "goalfailed",
    "goalinterrupted",
)


def map_invariants(world_map: WorldMap, *, register_capacity: int = REGISTER_CAPACITY) -> list[str]:
    """The violated invariants of ``world_map``, each as a sentence; empty when sound.

    Checked: IDs unique and non-empty within each class; every register at most
    ``register_capacity`` long; creation times non-negative, not after the map's
    ``lastupdatetime`` and non-decreasing along each list (lists keep creation order);
    ``robotstatus.setfields`` names RobotStatus fields, each once.
    """
    problems: list[str] = []
    for field in (*_DEVICE_LISTS, *_ENTITY_LISTS):
        seen: set[str] = set()
        for position, item in enumerate(getattr(world_map, field)):
            if not item.id:
                problems.append(f"{field}[{position}]: empty id")
            if item.id in seen:
                problems.append(f"{field}[{position}]: duplicate id {item.id!r}")
            seen.add(item.id)
    for field in _ENTITY_LISTS:
        previous = 0
        for position, entity in enumerate(getattr(world_map, field)):
            where = f"{field}[{position}] ({entity.id!r})"
            if entity.creationtime < 0:
                problems.append(f"{where}: negative creationtime {entity.creationtime}")
            if entity.creationtime > world_map.lastupdatetime:
                problems.append(
                    f"{where}: creationtime {entity.creationtime} is after the map's"
                    f" lastupdatetime {world_map.lastupdatetime}"
                )
            if entity.creationtime < previous:
                problems.append(f"{where}: created before the entity listed ahead of it")
            previous = max(previous, entity.creationtime)
            for register in _ENTITY_REGISTERS:
                size = len(getattr(entity, register))
                if size > register_capacity:
                    problems.append(
                        f"{where}.{register}: {size} entries, capacity {register_capacity}"
                    )
    status = world_map.robotstatus
    fields = set(status.__struct_fields__)
    if len(set(status.setfields)) != len(status.setfields):
        problems.append(f"robotstatus.setfields: duplicate names in {status.setfields}")
    for name in status.setfields:
        if name not in fields:
            problems.append(f"robotstatus.setfields: {name!r} is not a RobotStatus field")
    for register in _ROBOT_REGISTERS:
        size = len(getattr(world_map.robotstatus, register))
        if size > register_capacity:
            problems.append(f"robotstatus.{register}: {size} entries, capacity {register_capacity}")
    return problems
