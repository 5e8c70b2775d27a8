"""The Generator Handler (thesis 3.2, 5.1): the operator's commands, the selected activities,
the activity command button, and what the loop must do to the Block Reader's LIFO.

``handle`` either does a command fully and replies ``ok`` or refuses it with a
reason and changes nothing. Its effects are typed messages the loop applies:
:class:`PushScripts` and :class:`StopActivities`. Generators are user code: what one
raises, or a ``generate`` that returns no valid script, refuses the command or is said in
the reply or the log line (:func:`guarded`), and is kept for the loop to log at ERROR
(:meth:`GeneratorHandler.take_failures`); it never leaves the handler.

The button (``OperatorButton``)::

    get_ready --get_ready--> loading --tick--> start --start--> stop
        ^                                        ^  <--stop----  |
        +-- add / remove leaves a quiescent one  +-- last activity finished

Activities (``ActivityState``): ``not_yet_completed`` -> ``current`` (start, or
the previous one finished) -> ``completed`` (finished) or back to
``not_yet_completed`` (stop, or finished without completing); restart sets all
back to ``not_yet_completed``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Final

import msgspec
from oimi.pipeline.events import (
    ActivityEntry,
    ActivityState,
    Level,
    LogEntry,
    OperatorButton,
    OperatorReply,
    OperatorState,
)
from oimi.pipeline.messages import GeneratorNote, Message, Script, WorldMap
from oimi.pipeline.operator.commands import (
    Add,
    Clear,
    GetReady,
    ListActivities,
    OperatorCommand,
    Remove,
    Reorder,
    Restart,
    Start,
    Stop,
)
from oimi.pipeline.operator.generator import (
    Catalogue,
    Generator,
    GeneratorError,
    GeneratorFailure,
    GeneratorInfo,
    GeneratorView,
    failed,
    guarded,
    resolve_options,
)
from oimi.pipeline.plurals import counted
from oimi.pipeline.script.validate import script_errors

_LOADING: Final = OperatorButton.LOADING
"""Read at every tick: a global, not the enum class's slow attribute path."""


class SelectedScript(Message):
    """A selected activity's script."""

    activity: str
    """The selected activity's (generator's) name."""
    script: Script


class PushScripts(Message, tag="push_scripts", tag_field="effect"):
    """Put these scripts on the Block Reader's LIFO so they run in ``entries`` order.

    ``entries[0]`` runs first, so it must end on top: push ``lifo_order()``
    (``entries`` reversed, bottom to top, like ``ScriptInfo.script_vect``).
    """

    entries: tuple[SelectedScript, ...]

    def lifo_order(self) -> tuple[SelectedScript, ...]:
        """The entries bottom to top: push them in this order."""
        return tuple(reversed(self.entries))


class StopActivities(Message, tag="stop_activities", tag_field="effect"):
    """Interrupt the current script and drop the queued ones; the robot goes back to idle.

    ``activitynames`` are the scripts' ``activityname``s, the running one first.
    """

    activitynames: tuple[str, ...]


Effect = PushScripts | StopActivities


_Outcome = tuple[str, tuple[Effect, ...]]
"""A command done: the reply's text and the effects."""


class HandlerResult(Message):
    """A command's reply and what the loop must do (in order)."""

    reply: OperatorReply
    effects: tuple[Effect, ...] = ()


@dataclass
class _Selected:
    name: str
    options: dict[str, str]
    generator: Generator
    state: ActivityState = ActivityState.NOT_YET_COMPLETED
    script: Script | None = None
    quiesced: bool = False
    """A rule set its generator quiescent while its script ran."""


class _Refused(Exception):
    pass


class GeneratorHandler:
    """Runs the operator's commands against the catalogue's generators."""

    def __init__(self, catalogue: Catalogue):
        self._catalogue = catalogue
        self._selected: list[_Selected] = []
        self._button = OperatorButton.GET_READY
        self._seen: tuple[WorldMap | None, int] = (None, 0)
        """The map and time of the command being handled (what generators see)."""
        self._running: list[str] = []
        self._failures: list[LogEntry] = []
        """Names pushed at start and not finished yet, in run order (first = current)."""

    # ------------------------------------------------------------------ queries

    @property
    def button(self) -> OperatorButton:
        return self._button

    def describe(self) -> tuple[GeneratorInfo, ...]:
        """The catalogue, with options, for the app's selection and option screens."""
        return self._catalogue.describe()

    def activities(self) -> tuple[ActivityEntry, ...]:
        """The selected activities, top to bottom."""
        return tuple(
            ActivityEntry(name=s.name, options=dict(s.options), state=s.state)
            for s in self._selected
        )

    def running(self, name: str) -> str | None:
        """The selected activity the Block Reader runs when it runs ``name`` (activity or
        script name), if that is one pushed at start and not finished; else None."""
        s = self._running_entry(name)
        return s.name if s is not None else None

    def generated(self, name: str) -> Script | None:
        """The last script generated for the selected activity ``name``, if any."""
        s = self._find(name)
        return s.script if s is not None else None

    def state(
        self, tick: int, time_ms: int, *, replies: tuple[OperatorReply, ...] = ()
    ) -> OperatorState:
        """What the console shows after this tick."""
        return OperatorState(
            tick=tick,
            time_ms=time_ms,
            button=self._button,
            activities=self.activities(),
            replies=replies,
        )

    # ----------------------------------------------------------------- commands

    def handle(
        self, cmd: OperatorCommand, *, now_ms: int, world_map: WorldMap | None = None
    ) -> HandlerResult:
        """Do ``cmd`` completely or refuse it with a reason, changing nothing. ``world_map``
        is what generators see (a copy) when they generate."""
        self._seen = (world_map, now_ms)
        try:
            match cmd:
                case ListActivities():
                    reason, effects = self._list()
                case Add():
                    reason, effects = self._add(cmd)
                case Remove():
                    reason, effects = self._remove(cmd)
                case Reorder():
                    reason, effects = self._reorder(cmd)
                case GetReady():
                    reason, effects = self._get_ready()
                case Start():
                    reason, effects = self._start()
                case Stop():
                    reason, effects = self._stop()
                case Restart():
                    reason, effects = self._restart()
                case Clear():
                    reason, effects = self._clear()
        except _Refused as refused:
            return HandlerResult(reply=OperatorReply(id=cmd.id, ok=False, reason=str(refused)))
        return HandlerResult(
            reply=OperatorReply(id=cmd.id, ok=True, reason=reason), effects=effects
        )

    def tick(self, now_ms: int) -> bool:
        """Advance the clock: ``loading`` becomes ``start``; True when the state changed."""
        del now_ms
        if self._button is not _LOADING:
            return False
        self._button = OperatorButton.START
        return True

    def take_failures(self) -> list[LogEntry]:
        """The generators' failures since the last call (one raised or overran, or made no
        valid script), one ERROR entry each; the reply or note line that met it says it too.
        A generator's own ``GeneratorError`` (refusing its options) is not one."""
        failures, self._failures = self._failures, []
        return failures

    # ---------------------------------------------------------- loop callbacks

    def activity_started(self, name: str) -> bool:
        """The reader loaded ``name`` (activity or script name); False if not one of ours."""
        entry = self._running_entry(name)
        if entry is None:
            return False
        for s in self._selected:
            if s.state is ActivityState.CURRENT and s is not entry:
                s.state = ActivityState.NOT_YET_COMPLETED
        entry.state = ActivityState.CURRENT
        return True

    def activity_finished(self, name: str, *, completed: bool) -> bool:
        """The reader unloaded ``name``: completed, or back to not yet completed.

        The next pushed activity becomes current; after the last one the button
        shows ``start`` (the scripts stay generated; completed activities are
        not run again until ``restart``), or ``get_ready`` when a rule set a generator
        quiescent meanwhile. False if ``name`` is not one of ours.
        """
        entry = self._running_entry(name)
        if entry is None:
            return False
        entry.state = ActivityState.COMPLETED if completed else ActivityState.NOT_YET_COMPLETED
        self._running.remove(entry.name)
        if self._running:
            self._find(self._running[0]).state = ActivityState.CURRENT  # type: ignore[union-attr]
        else:
            for s in self._selected:
                if s.quiesced:  # a rule set it quiescent while it ran: Get Ready again
                    s.script, s.quiesced = None, False
            self._settle()
        return True

    def deliver(self, notes: Sequence[GeneratorNote]) -> list[str]:
        """Hand the rules' messages to the generators they name; a ``quiesce`` shuts the
        generator down and drops its script (the button shows Get Ready once nothing
        runs). Returns what happened, one line per note, for the log."""
        done = []
        for note in notes:
            s = self._find(note.generator)
            if s is None:
                done.append(f"rule {note.rule!r}: generator {note.generator!r} is not selected")
                continue
            if note.quiesce:
                trouble = self._shutdown(s)
                if s.name in self._running:
                    s.quiesced = True  # its script runs on; Get Ready once the run ends
                else:
                    s.script = None
                    if self._button is not OperatorButton.STOP:
                        self._settle()
                done.append(f"rule {note.rule!r} set generator {s.name!r} quiescent" + trouble)
                continue
            hear = getattr(s.generator, "hear", None)
            trouble = self._reported(s.name, "hear", hear, note) if hear is not None else ""
            done.append(f"rule {note.rule!r} told generator {s.name!r}: {note.text}" + trouble)
        return done

    # ----------------------------------------------------------------- helpers

    def _find(self, name: str) -> _Selected | None:
        for s in self._selected:
            if s.name == name:
                return s
        return None

    def _running_entry(self, name: str) -> _Selected | None:
        for running in self._running:
            s = self._find(running)
            if s is not None and (s.name == name or (s.script and s.script.activityname == name)):
                return s
        return None

    def _selected_or_refuse(self, name: str) -> _Selected:
        s = self._find(name)
        if s is None:
            raise _Refused(f"{name!r} is not selected")
        return s

    def _refuse_while(self, verb: str, *buttons: OperatorButton) -> None:
        if self._button in buttons:
            if self._button is OperatorButton.STOP:
                raise _Refused(f"cannot {verb} while the activities run; stop first")
            raise _Refused(f"cannot {verb} while the button shows {self._button.value}")

    def _failed(self, name: str, error: GeneratorError) -> None:
        """Keep ``error`` for :meth:`take_failures` when it is generator ``name``'s failure."""
        if isinstance(error, GeneratorFailure):
            self._failures.append(
                LogEntry(level=Level.ERROR, source="generators", message=str(error), ref=name)
            )

    def _reported(self, name: str, what: str, call: Callable[..., object], *args: object) -> str:
        """:func:`guarded`, for a call whose failure is only said: ``""``, or ``"; "`` and how
        it failed (to append to a reply or a log line)."""
        try:
            guarded(name, what, call, *args)
        except GeneratorError as error:
            self._failed(name, error)
            return f"; {error}"
        return ""

    def _shutdown(self, s: _Selected) -> str:
        """Shut ``s``'s generator down; :meth:`_reported`."""
        return self._reported(s.name, "shutdown", s.generator.shutdown)

    def _settle(self) -> None:
        """The button when nothing runs: ``start`` iff every selection has its script."""
        if self._selected and all(s.script is not None for s in self._selected):
            self._button = OperatorButton.START
        else:
            self._button = OperatorButton.GET_READY

    # ------------------------------------------------------------ the commands

    def _list(self) -> _Outcome:
        return "available: " + ", ".join(self._catalogue.names()), ()

    def _add(self, cmd: Add) -> _Outcome:
        self._refuse_while("add", OperatorButton.LOADING, OperatorButton.STOP)
        name = cmd.activity
        if name not in self._catalogue:
            available = ", ".join(self._catalogue.names()) or "none"
            raise _Refused(f"unknown generator {name!r} (available: {available})")
        if self._find(name) is not None:
            raise _Refused(f"{name!r} is already selected")
        info = self._catalogue.info(name)
        try:
            options = resolve_options(info.options, cmd.options, source=name)
            generator = guarded(name, "create", self._catalogue.create, name)
        except GeneratorError as err:
            self._failed(name, err)
            raise _Refused(str(err)) from None
        self._selected.append(_Selected(name, options, generator))
        self._button = OperatorButton.GET_READY
        return f"added {name!r}", ()

    def _remove(self, cmd: Remove) -> _Outcome:
        self._refuse_while("remove", OperatorButton.LOADING)
        s = self._selected_or_refuse(cmd.activity)
        if s.state is ActivityState.CURRENT:
            raise _Refused(f"{s.name!r} is running; stop first")
        if s.name in self._running:
            raise _Refused(f"{s.name!r} is queued to run; stop first")
        trouble = self._shutdown(s)
        self._selected.remove(s)
        if self._button is not OperatorButton.STOP:
            self._settle()
        return f"removed {s.name!r}" + trouble, ()

    def _reorder(self, cmd: Reorder) -> _Outcome:
        self._refuse_while("reorder", OperatorButton.LOADING, OperatorButton.STOP)
        s = self._selected_or_refuse(cmd.activity)
        last = len(self._selected) - 1
        if not 0 <= cmd.position <= last:
            raise _Refused(f"position {cmd.position} is out of range 0..{last}")
        self._selected.remove(s)
        self._selected.insert(cmd.position, s)
        return f"moved {s.name!r} to {cmd.position}", ()

    def _get_ready(self) -> _Outcome:
        if self._button is not OperatorButton.GET_READY:
            raise _Refused(f"cannot get ready while the button shows {self._button.value}")
        if not self._selected:
            raise _Refused("no activities selected; add one first")
        activated: list[_Selected] = []
        scripts: dict[str, Script] = {}
        name = ""  # the generator at work, for a failure's log entry
        try:
            for s in self._selected:
                name = s.name
                if s.script is not None:
                    scripts[s.name] = s.script
                    continue
                activated.append(s)
                world_map, now_ms = self._seen
                view = _view(world_map, now_ms) if world_map is not None else None
                scripts[s.name] = generate_script(s.name, s.generator, s.options, view)
            owners: dict[str, str] = {}
            for activity, script in scripts.items():
                other = owners.setdefault(script.activityname, activity)
                if other != activity:
                    raise GeneratorError(
                        f"its script is named {script.activityname!r} like {other!r}'s",
                        source=activity,
                    )
        except GeneratorError as err:
            self._failed(name, err)
            raise _Refused(str(err) + "".join(self._shutdown(s) for s in activated)) from None
        for s in self._selected:
            s.script = scripts[s.name]
        self._button = OperatorButton.LOADING
        return f"generated {counted(len(scripts), 'script')}", ()

    def _start(self) -> _Outcome:
        if self._button is not OperatorButton.START:
            hint = {
                OperatorButton.GET_READY: "; press get_ready first",
                OperatorButton.STOP: " already",
            }
            raise _Refused(
                f"cannot start while the button shows {self._button.value}"
                + hint.get(self._button, "")
            )
        todo = [s for s in self._selected if s.state is ActivityState.NOT_YET_COMPLETED]
        if not todo:
            raise _Refused("every activity is completed; press restart first")
        entries = tuple(SelectedScript(activity=s.name, script=s.script) for s in todo)  # type: ignore[arg-type]
        self._running = [s.name for s in todo]
        todo[0].state = ActivityState.CURRENT
        self._button = OperatorButton.STOP
        return f"started {counted(len(todo), 'activity')}", (PushScripts(entries=entries),)

    def _stop(self) -> _Outcome:
        if self._button is not OperatorButton.STOP:
            raise _Refused(f"cannot stop: nothing runs (the button shows {self._button.value})")
        names = tuple(self._find(n).script.activityname for n in self._running)  # type: ignore[union-attr]
        for s in self._selected:
            if s.state is ActivityState.CURRENT:
                s.state = ActivityState.NOT_YET_COMPLETED
        self._running = []
        self._button = OperatorButton.START
        return "stopped", (StopActivities(activitynames=names),)

    def _restart(self) -> _Outcome:
        self._refuse_while("restart", OperatorButton.LOADING, OperatorButton.STOP)
        for s in self._selected:
            s.state = ActivityState.NOT_YET_COMPLETED
        return "every activity is not yet completed", ()

    def _clear(self) -> _Outcome:
        self._refuse_while("clear", OperatorButton.LOADING, OperatorButton.STOP)
        trouble = "".join(self._shutdown(s) for s in self._selected)
        self._selected = []
        self._button = OperatorButton.GET_READY
        return "cleared" + trouble, ()


def generate_script(
    name: str, generator: Generator, options: Mapping[str, str], view: GeneratorView | None
) -> Script:
    """Activate ``generator``, let it see ``view`` (if any and it looks), generate: a valid
    script, or a :class:`GeneratorError` saying what failed."""
    guarded(name, "activate", generator.activate, options)
    see = getattr(generator, "see", None)
    if see is not None and view is not None:
        guarded(name, "see", see, view)
    script = guarded(name, "generate", generator.generate)
    if not isinstance(script, Script):
        kind = "None" if script is None else type(script).__name__
        raise failed(name, f"generate() returned {kind}, not a Script")
    problems = [error.message for error in script_errors(script)]
    if problems:
        raise GeneratorFailure("generated an invalid script: " + "; ".join(problems), source=name)
    return script


def _view(world_map: WorldMap, now_ms: int) -> GeneratorView:
    """A view on a deep copy of the map, so that a generator cannot change the loop's."""
    copy = msgspec.json.decode(msgspec.json.encode(world_map), type=WorldMap)
    return GeneratorView(world_map=copy, now_ms=now_ms)
