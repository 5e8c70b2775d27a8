"""A rule-forced switch names an activity, however its script was made (thesis 4.2 step 5)."""

from __future__ import annotations

from oimi.pipeline.events import Topic
from oimi.pipeline.operator.commands import Add, GetReady
from oimi.pipeline.sink import MemorySink
from oimi.pipeline.think.library import force_switch
from pipeline_with_generators import generating_pipeline


def test_a_rule_switch_reaches_a_generated_script_before_it_was_started() -> None:
    """Thesis 4.2 step 5: "the Block Reader loads the (Rule-setted) Script reported in field
    currentactivity"; 3.2: a Script Generator's role "is to produce Scripts on demand"."""
    sink = MemorySink()
    p = generating_pipeline(sink)  # no script files at all
    add = Add(id=1, activity="test_dance")
    p.tick(tick=0, commands=[add])
    p.tick(tick=1, commands=[GetReady(id=2)])
    p.tick(tick=2)
    force_switch(p.map, "test_dance")
    p.tick(tick=3)
    logs = [e.message for batch in sink.on(Topic.LOG) for e in batch.entries]
    assert not any("compulsory switch refused" in m for m in logs), logs
    assert p.map.scriptinfo.currentactivity == "test_dance"
    assert p.map.scriptinfo.scriptpath == "generator:test_dance"
