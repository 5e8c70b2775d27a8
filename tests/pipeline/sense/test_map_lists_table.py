"""The one table of the map's listed classes agrees with every place that reads a class."""

from __future__ import annotations

import msgspec
import pytest
from oimi.pipeline.messages import ENTITY_LISTS, MAP_LISTS, Entity, WorldMap
from oimi.pipeline.sense.updates import UPDATE_TABLE, EntityClass
from oimi.pipeline.think.condition_ast import CLASS_TYPES
from oimi.pipeline.think.functions import CLASS_NAMES


@pytest.mark.parametrize("row", MAP_LISTS, ids=lambda row: row.name)
def test_each_listed_class_has_a_map_field_of_its_struct_and_an_update_table(row) -> None:
    fields = {f.name: f.type for f in msgspec.structs.fields(WorldMap)}
    assert fields[row.field] == list[row.struct]
    assert EntityClass(row.name) in UPDATE_TABLE
    assert row.entity == issubclass(row.struct, Entity)


def test_the_condition_language_sees_the_entity_rows_and_activities() -> None:
    assert CLASS_NAMES == ("Human", "Obstacle", "Object", "Activity")
    assert [CLASS_TYPES[m.name] for m in ENTITY_LISTS] == [m.struct for m in ENTITY_LISTS]


def test_every_list_of_the_map_is_a_row() -> None:
    lists = {f.name for f in msgspec.structs.fields(WorldMap) if str(f.type).startswith("list")}
    assert lists == {m.field for m in MAP_LISTS}
