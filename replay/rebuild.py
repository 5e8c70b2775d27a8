"""Rebuilding a session from a recording: its attached scenario and scripts, its seed.

The recording carries the scenario file (``scenario/<file>``), every script of
its activity folders (``activities/<name>``) and the metadata of the run
(``scenario``: name, file, seed...; ``configuration``: the pipeline's set-up).
They are written into a temporary folder laid out as ``<tmp>/<file>`` and
``<tmp>/activities/`` (the scripts also beside the scenario: the recording keeps a script's
name, not the folder it came from), so that the attached scripts win over the installed
library: a recording replays with the scripts it was made with. The extensions it
used (``extensions/NAME/...``) are loaded from their attached sources.
"""

from __future__ import annotations

import contextlib
import functools
import tempfile
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING, Final, Protocol, TypeVar

import msgspec
from oimi.pipeline.errors import LocatedError
from oimi.pipeline.jsontree import ABSENT, differences
from oimi.pipeline.messages import FORMAT_VERSION
from oimi.recorder.errors import RecordingError
from oimi.recorder.metadata import RecordingMetadata
from oimi.recorder.reader import Recording
from oimi.scenarios.extensions import ATTACHMENT_PREFIX, LoadedExtension, load_extension
from oimi.scenarios.loader import parse_scenario
from oimi.scenarios.session.build import BuiltPipeline, build_pipeline

if TYPE_CHECKING:
    from oimi.scenarios.session.runner import Session

SCENARIO_PREFIX: Final = "scenario/"
ACTIVITY_PREFIX: Final = "activities/"


class Rebuilt(Protocol):
    """What a rebuild gives: a ``Session`` (rerun) or a ``BuiltPipeline`` (redrive)."""

    def metadata(self) -> RecordingMetadata: ...


R = TypeVar("R", bound=Rebuilt)


def _safe_name(name: str, *, source: str) -> str:
    """An attachment's file name, refusing anything that would leave the folder."""
    path = PurePosixPath(name)
    if len(path.parts) != 1 or path.name in ("", ".", "..") or "\0" in name or "\\" in name:
        raise RecordingError(f"attachment name {name!r} is not a plain file name", source=source)
    return path.name


def check_replayable(recording: Recording) -> None:
    """A replay compares every message with what this oimi writes: ``RecordingError`` for a
    recording of an older format version (still read by analysis and the viewers)."""
    version = recording.meta.oimi.format_version
    if version != str(FORMAT_VERSION):
        raise RecordingError(
            f"recorded with format version {version}: a replay compares every message with"
            f" what this oimi writes (format version {FORMAT_VERSION}); record the scenario"
            " again to replay it (oimi analyse, view and info still read this one)",
            source=recording.path,
        )


def rebuilt_session(recording: Recording) -> contextlib.AbstractContextManager[Session]:
    """A fresh ``Session`` of the recorded scenario with the recorded seed and scripts, its
    world included (rerun). The temporary folder lives as long as the context (scripts load
    lazily). Raises ``RecordingError`` when the recording lacks what a rebuild needs."""
    from oimi.scenarios.session.runner import Session

    return _rebuilt(recording, Session)


def rebuilt_pipeline(recording: Recording) -> contextlib.AbstractContextManager[BuiltPipeline]:
    """The recorded scenario's pipeline alone (``build_pipeline``), for redrive: no world is
    built, and no expectations are tracked. As ``rebuilt_session`` otherwise."""
    return _rebuilt(recording, functools.partial(build_pipeline, tracked=False))


@contextlib.contextmanager
def _rebuilt(recording: Recording, build: Callable[..., R]) -> Iterator[R]:
    """``build(loaded, seed=, overrides=)`` of the recording's attached scenario."""
    where = recording.path
    scenario_meta = recording.meta.scenario
    if scenario_meta is None or scenario_meta.file is None or scenario_meta.seed is None:
        raise RecordingError(
            "no 'scenario' metadata record with 'file' and 'seed':"
            " not the recording of a scenario run",
            source=where,
        )
    file_name = _safe_name(scenario_meta.file, source=where)
    raw = recording.attachments.get(SCENARIO_PREFIX + file_name)
    if raw is None:
        raise RecordingError(
            f"the scenario file {file_name!r} is not attached ({SCENARIO_PREFIX}{file_name})",
            source=where,
        )
    seed = scenario_meta.seed_number
    if seed is None:
        raise RecordingError(
            f"scenario seed {scenario_meta.seed!r} is not an integer", source=where
        )
    with tempfile.TemporaryDirectory(prefix="oimi-replay-") as folder:
        base = Path(folder)
        scripts = base / "activities"
        scripts.mkdir()
        for name, data in recording.attachments.items():
            if name.startswith(ACTIVITY_PREFIX):
                script = _safe_name(name.removeprefix(ACTIVITY_PREFIX), source=where)
                (scripts / script).write_bytes(data)
                (base / script).write_bytes(data)  # a script named beside the scenario
        source = base / file_name
        source.write_bytes(raw)
        extensions = _attached_extensions(recording, base / "extensions")
        try:
            loaded = parse_scenario(raw, source=source, base_dir=base, loaded_extensions=extensions)
            overrides: Mapping[str, str] | None = recording.meta.variation or None
            built = build(loaded, seed=seed, overrides=overrides)
        except LocatedError as error:  # a scenario or script error, placed in the temp folder
            text = str(error).replace(str(base) + "/", "")
            raise RecordingError(
                f"the attached scenario does not load: {text}", source=where
            ) from None
        yield built


def _attached_extensions(recording: Recording, folder: Path) -> list[LoadedExtension]:
    """The extensions the recording names, loaded from its attached sources; refused when
    their sources are missing or are not the ones recorded (their digest differs)."""
    where = recording.path
    recorded = recording.meta.extensions
    loaded = []
    for name in sorted(recorded):
        info = msgspec.json.decode(recorded[name])
        prefix = f"{ATTACHMENT_PREFIX}{name}/"
        files = {
            k.removeprefix(prefix): v
            for k, v in recording.attachments.items()
            if k.startswith(prefix)
        }
        if not files:
            raise RecordingError(
                f"extension {name!r} was used but its sources are not attached ({prefix}...)",
                source=where,
            )
        root = folder / name
        for relative, data in files.items():
            path = PurePosixPath(relative)
            if path.is_absolute() or ".." in path.parts:
                raise RecordingError(
                    f"attachment {prefix}{relative!r} leaves its folder", source=where
                )
            (root / path).parent.mkdir(parents=True, exist_ok=True)
            (root / path).write_bytes(data)
        module = info.get("module", name)
        entry = (
            root if (root / "__init__.py").is_file() else root / f"{module.rpartition('.')[2]}.py"
        )
        try:
            extension = load_extension(str(entry))
        except LocatedError as error:
            raise RecordingError(
                f"the attached extension {name!r} does not load: {error}", source=where
            ) from None
        if extension.digest != info.get("digest"):
            raise RecordingError(
                f"the attached sources of extension {name!r} are not the recorded ones"
                f" (digest {extension.digest}, recorded {info.get('digest')})",
                source=where,
            )
        loaded.append(extension)
    return loaded


def rebuild_notes(recording: Recording, session: Rebuilt) -> list[str]:
    """What differs between the recording's set-up and the rebuilt one (likely causes of a
    divergence): oimi's version, its registries' versions and the configuration, each
    field that differs on its own line (a field this oimi has and the recording lacks is
    new since: the session ran without it)."""
    now = session.metadata().records()
    notes = []
    for record in ("oimi", "configuration"):
        then = recording.metadata.get(record, {})
        for key, value in now.get(record, {}).items():
            if key in then and then[key] != value:
                notes += _differing(f"{record}.{key}", then[key], value)
    return notes


def _differing(name: str, then: str, now: str) -> list[str]:
    """Notes on a metadata record's field: its JSON's differing leaves, or both texts."""
    try:
        leaves = list(differences(msgspec.json.decode(then), msgspec.json.decode(now), name))
    except msgspec.DecodeError:
        leaves = []
    if not leaves:  # not JSON, or the same JSON written otherwise
        return [f"{name} differs: recorded {then}, now {now}"]
    return [
        f"{path} is new since the recording (now {_json(new)})"
        if old is ABSENT
        else f"{path} differs: recorded {_json(old)}, now {_json(new)}"
        for path, old, new in leaves
    ]


def _json(value: object) -> str:
    return "<absent>" if value is ABSENT else msgspec.json.encode(value).decode()
