"""What a session may call by name: rule functions, rule classes and script generators.

A :class:`Registries` is built per session by the composition root (the scenario
runner, redrive, ``oimi``): the built-ins plus whatever extensions add. It is
handed down to the loop, which gives the rule registry to the rule chain, the
function registry to the Block Reader (jump conditions) and the generators to the
Generator Handler's catalogue. Nothing here is module-level mutable state.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from oimi.pipeline.messages import Script
from oimi.pipeline.operator.generator import Catalogue, Generator
from oimi.pipeline.operator.generators import default_catalogue
from oimi.pipeline.think.functions import FunctionRegistry
from oimi.pipeline.think.library import BUILTIN_RULES
from oimi.pipeline.think.rules import Rule, RuleRegistry
from oimi.pipeline.think.stdlib import default_registry

GeneratorFactory = Callable[[], Generator]
"""Makes a fresh, quiescent generator (one per operator selection)."""


@dataclass(frozen=True, slots=True)
class Registries:
    """A session's functions (B/E/F), rules (by code) and extra script generators."""

    functions: FunctionRegistry
    rules: RuleRegistry
    generators: Mapping[str, GeneratorFactory] = field(default_factory=lambda: MappingProxyType({}))
    """Generators added to the shipped ones, by name."""

    @classmethod
    def build(
        cls,
        *,
        functions: Iterable[Callable[..., object]] = (),
        rules: Iterable[type[Rule]] = (),
        generators: Mapping[str, GeneratorFactory] | None = None,
    ) -> Registries:
        """The built-ins plus these (collisions raise ``ValueError``; extensions are checked
        earlier, with both origins named, by ``scenarios.extensions``)."""
        function_registry = FunctionRegistry([*default_registry().functions(), *functions])
        return cls(
            functions=function_registry,
            rules=RuleRegistry([*BUILTIN_RULES, *rules], functions=function_registry),
            generators=MappingProxyType(dict(generators or {})),
        )

    def catalogue(self, scripts: Mapping[str, Script] | None = None) -> Catalogue:
        """The shipped generators, these extra ones, then one static generator per script."""
        return default_catalogue(scripts, extra=self.generators)
