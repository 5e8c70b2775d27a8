"""The shipped Script Generators and the default catalogue."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from oimi.pipeline.messages import Script
from oimi.pipeline.operator.generator import Catalogue, Generator
from oimi.pipeline.operator.generators.blink import BlinkGenerator
from oimi.pipeline.operator.generators.dance import DanceGenerator
from oimi.pipeline.operator.generators.greeting import GreetingGenerator
from oimi.pipeline.operator.generators.joint_attention import JointAttentionGenerator
from oimi.pipeline.operator.generators.static import StaticScriptGenerator

__all__ = [
    "BlinkGenerator",
    "DanceGenerator",
    "GreetingGenerator",
    "JointAttentionGenerator",
    "StaticScriptGenerator",
    "default_catalogue",
]


def default_catalogue(
    scripts: Mapping[str, Script] | None = None,
    *,
    extra: Mapping[str, Callable[[], Generator]] | None = None,
) -> Catalogue:
    """The shipped generators, ``extra`` ones (an extension's), then one
    :class:`StaticScriptGenerator` per named script."""
    factories = {
        DanceGenerator.name: DanceGenerator,
        GreetingGenerator.name: GreetingGenerator,
        JointAttentionGenerator.name: JointAttentionGenerator,
        BlinkGenerator.name: BlinkGenerator,
    }
    catalogue = Catalogue(factories)
    if extra:
        catalogue = catalogue.with_factories(extra)
    if scripts:
        catalogue = catalogue.with_factories(
            {name: _static(name, script) for name, script in scripts.items()}
        )
    return catalogue


def _static(name: str, script: Script):
    return lambda: StaticScriptGenerator(name, script)
