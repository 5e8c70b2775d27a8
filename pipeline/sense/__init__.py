"""The world map's producer: sensors' MapUpdates judged (tables 4.1/4.2) and applied."""

from oimi.pipeline.sense.invariants import map_invariants
from oimi.pipeline.sense.producer import MAX_ENTITIES, MapProducer, Rejection
from oimi.pipeline.sense.updates import (
    UPDATE_TABLE,
    DecodedUpdate,
    EntityClass,
    MapUpdateError,
    Storage,
    decode_update,
    parse_objectid,
)

__all__ = [
    "MAX_ENTITIES",
    "UPDATE_TABLE",
    "DecodedUpdate",
    "EntityClass",
    "MapProducer",
    "MapUpdateError",
    "Rejection",
    "Storage",
    "decode_update",
    "map_invariants",
    "parse_objectid",
]
