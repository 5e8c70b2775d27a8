"""A generator that hands out a script read by the edge (a ``.json`` or DSL file)."""

from __future__ import annotations

from collections.abc import Mapping

from oimi.pipeline.messages import Script
from oimi.pipeline.operator.generator import GeneratorError, OptionSpec


class StaticScriptGenerator:
    """Wraps one ready-made :class:`Script`; it takes no options."""

    options: tuple[OptionSpec, ...] = ()

    def __init__(self, name: str, script: Script, *, title: str = "", description: str = ""):
        self.name = name
        self.title = title or name
        self.description = description or f"The script {script.activityname!r}."
        self._script = script
        self._active = False

    def activate(self, options: Mapping[str, str]) -> None:
        for option in sorted(options):
            raise GeneratorError(
                f"unknown option {option!r} (options: none)", source=self.name, option=option
            )
        self._active = True

    def generate(self) -> Script:
        if not self._active:
            raise GeneratorError("generate called before activate", source=self.name)
        return self._script

    def shutdown(self) -> None:
        self._active = False
