"""Generators are user code: whatever one raises, or a script that is not one, is a refusal or
a report naming the generator and what failed, and never leaves the Generator Handler."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import pytest
from oimi.pipeline.events import Level, LogEntry
from oimi.pipeline.messages import GeneratorNote, Script, WorldMap
from oimi.pipeline.operator.commands import Add, Clear, Command, GetReady, Remove, Start
from oimi.pipeline.operator.generator import (
    BaseGenerator,
    Catalogue,
    GeneratorError,
    OptionValue,
    guarded,
)
from oimi.pipeline.operator.generators.build import ScriptBuilder, led
from oimi.pipeline.operator.handler import GeneratorHandler, OperatorButton

HERE = Path(__file__).name


def boom(what: str) -> None:
    raise KeyError(f"{what} boom")


BOOM = f"KeyError: '%s boom' ({HERE}:{boom.__code__.co_firstlineno + 1})"
"""What ``boom(what)`` raised, as a refusal says it (``%`` the ``what``)."""


def script(name: str) -> Script:
    b = ScriptBuilder(name)
    b.goal("g")
    b.instruction(leds=(led((0.0, 0.0, 1.0), duration_ms=100),))
    return b.build()


class Faulty(BaseGenerator):
    """Raises in the methods named in ``fail`` (or ``returns`` that from build); logs calls."""

    def __init__(self, name: str, log: list[str], fail: str = "", returns: object = None):
        if fail == "__init__":
            boom("init")
        super().__init__()
        self.name = name
        self.log, self.fail, self.returns = log, fail, returns

    def _call(self, what: str) -> None:
        self.log.append(f"{what} {self.name}")
        if what in self.fail.split():
            boom(what)

    def activate(self, options: Mapping[str, str]) -> None:
        self._call("activate")
        super().activate(options)

    def see(self, view) -> None:
        self._call("see")
        super().see(view)

    def hear(self, note: GeneratorNote) -> None:
        self._call("hear")

    def shutdown(self) -> None:
        self._call("shutdown")
        super().shutdown()

    def build(self, values: Mapping[str, OptionValue]) -> Script:
        self._call("build")
        return self.returns if "returns" in self.fail else script(self.name)  # type: ignore[return-value]


class Env:
    def __init__(self, **faults: dict[str, object]):
        self.log: list[str] = []
        names = {"good": {}, **faults}
        self.h = GeneratorHandler(
            Catalogue(
                {n: (lambda n=n, kw=kw: Faulty(n, self.log, **kw)) for n, kw in names.items()}
            )
        )
        self.ids = 0

    def do(self, kind: type[Command], activity: str = ""):
        self.ids += 1
        cmd = kind(id=self.ids, **({"activity": activity} if activity else {}))
        return self.h.handle(cmd, now_ms=self.ids * 20, world_map=WorldMap())

    def ok(self, kind: type[Command], activity: str = "") -> str:
        result = self.do(kind, activity)
        assert result.reply.ok, result.reply.reason
        return result.reply.reason

    def snapshot(self):
        generated = {e.name: self.h.generated(e.name) for e in self.h.activities()}
        return self.h.button, self.h.activities(), generated

    def refused(self, kind: type[Command], activity: str = "") -> str:
        before = self.snapshot()
        result = self.do(kind, activity)
        assert not result.reply.ok and result.effects == ()
        assert self.snapshot() == before, "a refused command changes nothing"
        return result.reply.reason


def test_a_constructor_that_raises_refuses_the_add() -> None:
    calls = {"make": 0}

    def make() -> Faulty:
        calls["make"] += 1
        return Faulty("ctor", [], fail="__init__" if calls["make"] > 1 else "")

    h = GeneratorHandler(Catalogue({"ctor": make}))  # the catalogue's own instance is fine
    reply = h.handle(Add(id=1, activity="ctor"), now_ms=0).reply
    assert not reply.ok
    assert reply.reason == "generator 'ctor': create() raised " + BOOM % "init"
    assert h.activities() == () and h.button is OperatorButton.GET_READY


@pytest.mark.parametrize("fail", ["activate", "see", "build"])
def test_a_raising_lifecycle_call_refuses_get_ready_and_shuts_the_others_down(fail) -> None:
    env = Env(bad={"fail": fail})
    env.ok(Add, "good")
    env.ok(Add, "bad")
    env.log.clear()
    what = {"build": "generate"}.get(fail, fail)
    assert env.refused(GetReady) == f"generator 'bad': {what}() raised " + BOOM % fail
    assert env.log[-2:] == ["shutdown good", "shutdown bad"]
    assert env.h.button is OperatorButton.GET_READY


@pytest.mark.parametrize(("returns", "kind"), [(None, "None"), ({"goals": []}, "dict")])
def test_a_generate_that_returns_no_script_refuses_get_ready(returns, kind) -> None:
    env = Env(bad={"fail": "returns", "returns": returns})
    env.ok(Add, "bad")
    assert env.refused(GetReady) == f"generator 'bad': generate() returned {kind}, not a Script"


def test_a_failing_shutdown_while_refusing_is_said_in_the_reason() -> None:
    env = Env(bad={"fail": "build shutdown"})
    env.ok(Add, "bad")
    assert env.refused(GetReady) == (
        "generator 'bad': generate() raised "
        + BOOM % "build"
        + "; generator 'bad': shutdown() raised "
        + BOOM % "shutdown"
    )


def test_after_a_refusal_a_fixed_generator_gets_ready() -> None:
    env = Env(bad={"fail": "build"})
    env.ok(Add, "bad")
    env.refused(GetReady)
    env.h._selected[0].generator.fail = ""  # type: ignore[attr-defined]
    env.ok(GetReady)
    env.h.tick(0)
    assert env.h.button is OperatorButton.START


def test_a_failing_shutdown_still_removes_and_clears_and_says_so() -> None:
    env = Env(bad={"fail": "shutdown"}, worse={"fail": "shutdown"})
    for name in ("good", "bad", "worse"):
        env.ok(Add, name)
    assert env.ok(Remove, "bad") == (
        "removed 'bad'; generator 'bad': shutdown() raised " + BOOM % "shutdown"
    )
    assert [e.name for e in env.h.activities()] == ["good", "worse"]
    assert env.ok(Clear) == "cleared; generator 'worse': shutdown() raised " + BOOM % "shutdown"
    assert env.h.activities() == () and env.h.button is OperatorButton.GET_READY


def note(generator: str, *, quiesce: bool = False) -> GeneratorNote:
    return GeneratorNote(generator=generator, rule="r1", text="hi", quiesce=quiesce)


def test_deliver_reports_a_failing_hear_or_shutdown_on_the_log_line() -> None:
    env = Env(deaf={"fail": "hear"}, stuck={"fail": "shutdown"})
    for name in ("good", "deaf", "stuck"):
        env.ok(Add, name)
    env.ok(GetReady)
    env.h.tick(0)
    lines = env.h.deliver([note("good"), note("deaf"), note("stuck", quiesce=True)])
    assert lines == [
        "rule 'r1' told generator 'good': hi",
        "rule 'r1' told generator 'deaf': hi; generator 'deaf': hear() raised " + BOOM % "hear",
        "rule 'r1' set generator 'stuck' quiescent; generator 'stuck': shutdown() raised "
        + BOOM % "shutdown",
    ]
    assert env.h.generated("stuck") is None, "quiescent all the same: its script is dropped"
    assert env.h.button is OperatorButton.GET_READY


def test_a_failing_hear_while_running_leaves_the_run_alone() -> None:
    env = Env(deaf={"fail": "hear"})
    env.ok(Add, "deaf")
    env.ok(GetReady)
    env.h.tick(0)
    env.ok(Start)
    assert env.h.deliver([note("deaf")])[0].endswith(BOOM % "hear")
    assert env.h.button is OperatorButton.STOP


def test_guarded_passes_generator_errors_and_base_exceptions_through() -> None:
    assert guarded("g", "generate", lambda x: x + 1, 1) == 2

    def interrupted() -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        guarded("g", "generate", interrupted)


def test_a_catalogue_whose_generator_cannot_be_made_names_it() -> None:
    with pytest.raises(GeneratorError) as caught:
        Catalogue({"shy": lambda: Faulty("shy", [], fail="__init__")})
    assert str(caught.value) == "generator 'shy': create() raised " + BOOM % "init"


def failure(name: str, text: str) -> LogEntry:
    return LogEntry(level=Level.ERROR, source="generators", message=text, ref=name)


def test_each_failure_is_kept_for_the_log_at_error_once() -> None:
    env = Env(bad={"fail": "build shutdown"}, deaf={"fail": "hear"})
    env.ok(Add, "bad")
    env.refused(GetReady)
    assert env.h.take_failures() == [
        failure("bad", "generator 'bad': generate() raised " + BOOM % "build"),
        failure("bad", "generator 'bad': shutdown() raised " + BOOM % "shutdown"),
    ]
    assert env.h.take_failures() == [], "taken once"
    env.ok(Remove, "bad")
    env.h.take_failures()
    env.ok(Add, "deaf")
    env.ok(GetReady)
    assert env.h.take_failures() == []
    env.h.deliver([note("deaf")])
    assert env.h.take_failures() == [
        failure("deaf", "generator 'deaf': hear() raised " + BOOM % "hear")
    ]


def test_an_invalid_script_is_a_failure() -> None:
    env = Env(bad={"fail": "returns", "returns": None})
    env.ok(Add, "bad")
    env.refused(GetReady)
    assert [e.message for e in env.h.take_failures()] == [
        "generator 'bad': generate() returned None, not a Script"
    ]


class Refusing(BaseGenerator):
    """Refuses every option set with its own GeneratorError: a refusal, not a failure."""

    name = "picky"

    def activate(self, options: Mapping[str, str]) -> None:
        raise GeneratorError("not today", source=self.name)

    def build(self, values: Mapping[str, OptionValue]) -> Script:
        return script(self.name)


def test_a_refusal_of_its_own_or_a_bad_option_is_no_failure() -> None:
    h = GeneratorHandler(Catalogue({"picky": Refusing}))
    assert not h.handle(Add(id=1, activity="picky", options={"x": "1"}), now_ms=0).reply.ok
    assert h.handle(Add(id=2, activity="picky"), now_ms=0).reply.ok
    reply = h.handle(GetReady(id=3), now_ms=0).reply
    assert not reply.ok and reply.reason == "picky: not today"
    assert h.take_failures() == []


class Mislabelled(BaseGenerator):
    """Jumps to a label it misspelt: the builder's error is the generator's bug."""

    name = "mislabelled"

    def build(self, values: Mapping[str, OptionValue]) -> Script:
        b = ScriptBuilder(self.name)
        b.goal("g")
        b.jump("! {TRUE}", false="mroe")
        b.instruction(leds=(led((0.0, 0.0, 1.0), duration_ms=100),), label="more")
        return b.build()


def test_a_builder_error_is_a_failure_that_suggests_the_label_meant() -> None:
    h = GeneratorHandler(Catalogue({"mislabelled": Mislabelled}))
    assert h.handle(Add(id=1, activity="mislabelled"), now_ms=0).reply.ok
    reply = h.handle(GetReady(id=2), now_ms=0).reply
    said = "mislabelled: jump to unknown label 'mroe'; did you mean 'more'?"
    assert not reply.ok and reply.reason == said
    assert h.take_failures() == [failure("mislabelled", said)], "logged at ERROR"
