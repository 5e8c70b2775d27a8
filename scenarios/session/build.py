"""A session's pipeline without its world: what a ``Session`` ticks with the simulation and
what replay's redrive feeds recorded inputs to (no pymunk world is built for it).

``build_pipeline`` applies the session's overrides and seed to the scenario, gathers its
activity library, and wires the pipeline to a ``FanOut`` of the expectations' ``Tracker`` and
the given sinks; the result also writes the recording's metadata and attachments.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping, Sequence
from importlib import metadata as package_metadata

import msgspec
from oimi.pipeline.act.limits import RobotLimits
from oimi.pipeline.loop import Pipeline, PipelineConfig
from oimi.pipeline.messages import FORMAT_VERSION, Script
from oimi.pipeline.operator.handler import GeneratorHandler
from oimi.pipeline.registries import Registries
from oimi.pipeline.sink import FanOut, Sink
from oimi.pipeline.think import library as rule_library
from oimi.recorder.metadata import (
    ConfigurationRecord,
    OimiRecord,
    RecordingMetadata,
    ScenarioRecord,
)
from oimi.scenarios.extensions import extension_attachments, extensions_metadata
from oimi.scenarios.loader import LoadedScenario, apply_overrides
from oimi.scenarios.safety import supervisor_config
from oimi.scenarios.schema import Scenario
from oimi.scenarios.session.activities import ACTIVITIES, ActivityLibrary
from oimi.scenarios.session.expectations import Tracker


def pipeline_config(scenario: Scenario) -> PipelineConfig:
    """The pipeline's configuration for a scenario (tick length, robot limits and safety:
    the supervisor's assumptions it leaves out cover its robot, humans and sensors)."""
    robot = scenario.robot
    return PipelineConfig(
        tick_ms=scenario.tick_ms,
        limits=RobotLimits(
            max_speed_mps=robot.max_speed_mps,
            max_angular_speed_radps=robot.max_angular_speed_radps,
            max_accel_mps2=robot.max_accel_mps2,
            max_angular_accel_radps2=robot.max_angular_accel_radps2,
        ),
        safety=supervisor_config(scenario),
    )


class BuiltPipeline:
    """A scenario's pipeline set up for one session, with what it was built from."""

    def __init__(
        self,
        loaded: LoadedScenario,
        scenario: Scenario,
        overrides: dict[str, str],
        library: ActivityLibrary,
        scripts: dict[str, Script],
        sink: FanOut,
        tracker: Tracker | None,
        pipeline: Pipeline,
    ) -> None:
        self.loaded = loaded
        self.scenario = scenario
        self.overrides = overrides
        self.toolkit = loaded.toolkit
        self.registries: Registries = loaded.toolkit.registries
        self.library = library
        self.scripts = scripts
        self.sink = sink
        self.tracker = tracker
        self.pipeline = pipeline
        self.config = pipeline.config

    def metadata(self) -> RecordingMetadata:
        """The recording's metadata: enough, with the attachments, to rebuild this run."""
        s = self.scenario
        return RecordingMetadata(
            oimi=OimiRecord(
                version=_version(),
                format_version=str(FORMAT_VERSION),
                rule_registry=self.registries.rules.version,
                function_registry=self.registries.functions.version,
            ),
            scenario=ScenarioRecord(
                name=s.name,
                file=self.loaded.source.name,
                seed=str(s.seed),
                tick_hz=str(s.tick_hz),
                duration_s=repr(s.duration_s),
                ticks=str(s.ticks),
            ),
            configuration=ConfigurationRecord(
                pipeline=msgspec.json.encode(self.config).decode(),
                robot=msgspec.json.encode(s.robot).decode(),
                sensors=msgspec.json.encode(s.sensors).decode(),
            ),
            variation=dict(self.overrides) if self.overrides else {},
            extensions=extensions_metadata(self.toolkit.extensions)
            if self.toolkit.extensions
            else {},
        )

    def attachments(self) -> list[tuple[str, bytes]]:
        """The scenario file, every script its activity folders hold (first folder wins a name;
        a ``.json`` or ``.txt`` that is not a script, such as notes beside the scenario, is
        not one and stays out of the recording), the rule library's source and every
        extension's sources (``extensions/NAME/PATH``)."""
        files = [(f"scenario/{self.loaded.source.name}", self.loaded.raw)]
        seen: set[str] = set()
        for folder in self.library.folders:
            for path in sorted([*folder.glob("*.json"), *folder.glob("*.txt")]):
                if path.name not in seen and self.library.holds_script(path):
                    seen.add(path.name)
                    files.append((f"activities/{path.name}", path.read_bytes()))
        files.append(("rules/library.py", inspect.getsource(rule_library).encode()))
        files += extension_attachments(self.toolkit.extensions)
        return files


def build_pipeline(
    loaded: LoadedScenario,
    *,
    sinks: Sequence[Sink] = (),
    seed: int | None = None,
    overrides: Mapping[str, str] | None = None,
    tracked: bool = True,
) -> BuiltPipeline:
    """The pipeline of one session of ``loaded``: ``overrides``
    (``scenarios.loader.apply_overrides``, recorded as ``variation``) and ``seed`` applied,
    its activity library searched in the scenario's folder, its ``activities/``, the shipped
    library and the extensions' folders. ``tracked``: a :class:`Tracker` follows what it
    emits, for the session's summary and verdicts (a redrive needs neither)."""
    scenario = loaded.scenario
    changes = dict(overrides or {})
    if changes:
        scenario = apply_overrides(scenario, changes)
    if seed is not None:
        scenario = msgspec.structs.replace(scenario, seed=seed)
    library = ActivityLibrary(
        [
            loaded.source.parent,
            loaded.source.parent / "activities",
            ACTIVITIES,
            *loaded.toolkit.activity_folders,
        ]
    )
    scripts: dict[str, Script] = {}
    for path in loaded.activity_paths:
        if path is not None:
            script = library.load(path)
            scripts[script.activityname] = script
    tracker = Tracker(scenario) if tracked else None
    sink = FanOut(tracker, *sinks) if tracker is not None else FanOut(*sinks)
    registries = loaded.toolkit.registries
    pipeline = Pipeline(
        pipeline_config(scenario),
        idle=library.idle(),
        resolve=library.resolve,
        handler=GeneratorHandler(registries.catalogue(scripts)),
        sink=sink,
        registries=registries,
    )
    return BuiltPipeline(loaded, scenario, changes, library, scripts, sink, tracker, pipeline)


def _version() -> str:
    try:
        return package_metadata.version("oimi")
    except package_metadata.PackageNotFoundError:
        return "0+unknown"
