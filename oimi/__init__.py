"""oimi: a toolkit for social assistive robots (the thesis's modular architecture).

The public Python API is :mod:`oimi.api`, re-exported here (``oimi.run(...)``,
``oimi.Extension``...); it is imported on first use, so ``python -m oimi`` starts fast.
See ``docs/extending.md``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from oimi import accel

accel.install()  # the compiled hot modules, if built for their sources (OIMI_PURE=1: none)

if TYPE_CHECKING:
    from oimi.api import (
        Extension,
        LoadedScenario,
        RunOutcome,
        Scenario,
        Toolkit,
        check_scenario,
        compile_script,
        condition,
        evaluate,
        load_scenario,
        open_recording,
        run,
        script_json,
        toolkit,
    )

__all__ = [
    "Extension",
    "LoadedScenario",
    "RunOutcome",
    "Scenario",
    "Toolkit",
    "check_scenario",
    "compile_script",
    "condition",
    "evaluate",
    "load_scenario",
    "open_recording",
    "run",
    "script_json",
    "toolkit",
]


def __getattr__(name: str) -> object:
    if name in __all__:
        import importlib

        return getattr(importlib.import_module("oimi.api"), name)
    raise AttributeError(f"module 'oimi' has no attribute {name!r}")
