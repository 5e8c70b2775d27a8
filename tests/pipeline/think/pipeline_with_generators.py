"""A pipeline whose operator has the shipped generators and no script files (for tests)."""

from __future__ import annotations

from oimi.pipeline.loop import Pipeline, PipelineConfig
from oimi.pipeline.operator.generators import default_catalogue
from oimi.pipeline.operator.handler import GeneratorHandler
from oimi.pipeline.sink import MemorySink
from oimi.scenarios.session.activities import ACTIVITIES, ActivityLibrary

IDLE = ActivityLibrary([ACTIVITIES]).idle()
"""The shipped idle activity."""


def generating_pipeline(sink: MemorySink) -> Pipeline:
    """The shipped idle activity, the shipped generators, no script files at all."""
    return Pipeline(
        PipelineConfig(),
        idle=IDLE,
        resolve=lambda name: None,
        handler=GeneratorHandler(default_catalogue()),
        sink=sink,
    )
