"""A ``script_vect`` update (thesis 4.5, table 4.2) reorders a LIFO of generated scripts,
which the map lists as ``generator:NAME``."""

from __future__ import annotations

from oimi.pipeline.events import Topic
from oimi.pipeline.loop import Pipeline
from oimi.pipeline.messages import MapUpdate, Policy
from oimi.pipeline.operator.commands import Add, GetReady, Start
from oimi.pipeline.sink import MemorySink
from pipeline_with_generators import generating_pipeline


def started(*activities: str) -> tuple[Pipeline, MemorySink]:
    """A pipeline whose operator selected ``activities``, readied and started them."""
    sink = MemorySink()
    p = generating_pipeline(sink)
    adds = [Add(id=i, activity=a) for i, a in enumerate(activities, start=1)]
    p.tick(tick=0, commands=adds)
    p.tick(tick=1, commands=[GetReady(id=10)])
    p.tick(tick=2, commands=[Start(id=11)])
    p.tick(tick=3)
    return p, sink


def script_vect(tick: int, *entries: str, restart: bool = False) -> MapUpdate:
    listed = ", ".join(f'"{e}"' for e in entries)
    flag = "s_true" if restart else "s_false"
    return MapUpdate(
        objectid="Script",
        attributename="script_vect",
        policy=Policy.R,
        jsonmsg=f'{{"restart": "{flag}", "update": [{listed}]}}',
        seq=tick,
    )


def logs(sink: MemorySink) -> list[str]:
    return [e.message for batch in sink.on(Topic.LOG) for e in batch.entries]


def test_an_update_reorders_the_generated_scripts_waiting_in_the_lifo() -> None:
    p, sink = started("test_dance", "greeting", "joint_attention")
    info = p.map.scriptinfo
    assert info.currentactivity == "test_dance"
    assert info.script_vect == ["generator:joint_attention", "generator:greeting"]
    p.tick(tick=4, updates=[script_vect(4, "generator:greeting", "generator:joint_attention")])
    assert info.script_vect == ["generator:greeting", "generator:joint_attention"]
    assert [e.source for e in p.reader.lifo] == info.script_vect
    p.tick(tick=5, updates=[script_vect(5, "generator:greeting", restart=True)])
    assert info.currentactivity == "greeting", "restart: the top of the new LIFO runs"
    assert info.script_vect == [] and not any("skipped" in m for m in logs(sink))


def test_an_entry_for_an_activity_not_generated_is_skipped_with_a_warning() -> None:
    p, sink = started("test_dance", "greeting")
    p.tick(tick=4, updates=[script_vect(4, "generator:greeting", "generator:nobody")])
    assert p.map.scriptinfo.script_vect == ["generator:greeting"]
    assert "script_vect: no script 'generator:nobody'; skipped" in logs(sink)
