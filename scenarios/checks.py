"""Checking scripts (.txt DSL, .json), scenarios (.toml) and rule conditions without running
them (``oimi check``): every problem, located, and warnings that are not failures.

A rule code the rule library does not know is a warning (the chain will refuse that
message at run time), not a failure; so is an alfa message whose change no omega message
undoes (thesis 4.4: when the script is over, its omega restores the previous situation).
"""

from __future__ import annotations

import difflib
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import NamedTuple

from oimi.pipeline.errors import LocatedError
from oimi.pipeline.messages import RuleAction
from oimi.pipeline.script import ParsedScript, ScriptError
from oimi.pipeline.script.sourcemap import LineIndex
from oimi.pipeline.think.condition_ast import bound_aliases, unbound_aliases
from oimi.pipeline.think.condition_parse import parse_condition
from oimi.pipeline.think.conditions import compile_condition
from oimi.pipeline.think.functions import FunctionRegistry
from oimi.pipeline.think.rules import RuleRegistry
from oimi.scenarios.extensions import (
    USER_RULE_CODES,
    Toolkit,
    build_toolkit,
    load_extensions,
)
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.activities import check_script_file


class FileCheck(NamedTuple):
    """One file's problems (none: it is fine) and warnings (rule codes the library lacks, a
    scenario's sonar ring too short for the safety supervisor)."""

    file: str
    errors: list[LocatedError]
    warnings: Sequence[LocatedError]


class ConditionCheck(NamedTuple):
    """The ``number``-th condition given: ``error`` is ``""`` when it compiles, else
    ``<condition N>:LINE:COL: message``, and ``context`` its line with a caret under the
    column (as a script's errors have)."""

    number: int
    text: str
    error: str
    context: str = ""
    warnings: tuple[str, ...] = ()
    """What compiles but reads as a mistake (:func:`condition_warnings`)."""


def check(
    files: Sequence[str],
    conditions: Sequence[str] = (),
    *,
    allow_outside: bool = False,
    extensions: Sequence[str] = (),
) -> Iterator[FileCheck | ConditionCheck]:
    """Each file's check, then each condition's, one at a time (with the built-ins plus
    ``extensions``; a bad extension raises before the first)."""
    toolkit = build_toolkit(load_extensions(extensions))
    for name in files:
        checked = check_file(
            Path(name), allow_outside=allow_outside, extensions=extensions, toolkit=toolkit
        )
        yield checked._replace(file=name)  # as given
    for number, text in enumerate(conditions, start=1):
        error = condition_error(text, toolkit)
        if error is None:
            yield ConditionCheck(number, text, "", warnings=condition_warnings(text, number))
        else:
            where = LineIndex(text).context(error.line, error.column) if error.line else ""
            yield ConditionCheck(number, text, str(error.located(f"<condition {number}>")), where)


def check_file(
    path: Path,
    *,
    allow_outside: bool = False,
    extensions: Sequence[str] = (),
    toolkit: Toolkit | None = None,
) -> FileCheck:
    """Every problem found in one file, with these extensions (``toolkit``: already built
    from them)."""
    if path.suffix.lower() == ".toml":
        return _check_scenario(path, allow_outside=allow_outside, extensions=extensions)
    toolkit = toolkit or build_toolkit(load_extensions(extensions))
    parsed, errors = check_script_file(path, functions=toolkit.registries.functions)
    warnings = (
        []
        if parsed is None
        else unknown_rule_codes(parsed, toolkit.registries.rules) + unrestored_rules(parsed)
    )
    return FileCheck(str(path), errors, warnings)


_EXTENSION_HINT = (
    f" (codes from {USER_RULE_CODES} are extensions' rules: name the extension with --extension,"
    " or in the scenario's extensions)"
)


def unknown_rule_codes(parsed: ParsedScript, rules: RuleRegistry) -> list[ScriptError]:
    """Alfa/omega messages naming a rule code the rule library does not have."""
    script = parsed.script
    return [
        parsed.sourcemap.place(
            ScriptError(
                f"rule code {message.rulecode} ({message.id}) is not in the rule library"
                + (_EXTENSION_HINT if message.rulecode >= USER_RULE_CODES else ""),
                path=f"{kind}[{index}].rulecode",
            )
        )
        for kind, messages in (
            ("alfarulemessages", script.alfarulemessages),
            ("omegarulemessages", script.omegarulemessages),
        )
        for index, message in enumerate(messages)
        if message.rulecode not in rules
    ]


_LEFT: dict[RuleAction, tuple[str, str]] = {
    RuleAction.A: ("adds", "in"),
    RuleAction.B: ("brings back", "in"),
    RuleAction.C: ("recovers", "in"),
    RuleAction.R: ("removes", "out of"),
}
"""What an alfa message leaves behind when no omega message names its rule. ``D`` is not
there: a rule delayed "for a future usage" (thesis 4.4) outlives its script by design."""


def unrestored_rules(parsed: ParsedScript) -> list[ScriptError]:
    """Alfa messages on a rule that no omega message names: the change stays after the
    script ends, for the activities that follow (the thesis's own ``example_act`` adds
    ``my_rule`` this way)."""
    script = parsed.script
    restored = {message.id for message in script.omegarulemessages}
    return [
        parsed.sourcemap.place(
            ScriptError(
                f"the alfa {_LEFT[message.action][0]} {message.id} ({message.action.name}) "
                f"and no omega message names it: it stays {_LEFT[message.action][1]} the "
                "chain after the script ends",
                path=f"alfarulemessages[{index}].id",
            )
        )
        for index, message in enumerate(script.alfarulemessages)
        if message.id not in restored and message.action in _LEFT
    ]


def check_scenario_file(
    path: Path, *, allow_outside: bool = False, extensions: Sequence[str] = ()
) -> list[LocatedError]:
    """A scenario's problems: everything ``oimi run`` would refuse, ranges, the robot's
    ceiling, its scripts and generators (``scenarios.loader.load_scenario`` checks it all)."""
    return _check_scenario(path, allow_outside=allow_outside, extensions=extensions).errors


def _check_scenario(path: Path, *, allow_outside: bool, extensions: Sequence[str]) -> FileCheck:
    """A scenario's problems, or its warnings when it has none."""
    try:
        loaded = load_scenario(path, allow_outside=allow_outside, extensions=extensions)
    except LocatedError as error:
        return FileCheck(str(path), [error, *error.also], [])
    except OSError as error:
        problem = LocatedError(f"cannot read the file: {error.strerror}", source=str(path))
        return FileCheck(str(path), [problem], [])
    return FileCheck(str(path), [], list(loaded.warnings))


def condition_warnings(text: str, number: int) -> tuple[str, ...]:
    """``<condition N>:LINE:COL: ...`` for each alias a compiling condition reads that none
    of its ``CLASS`` clauses binds (a mistyped alias is never bound: its calls are false),
    with the nearest alias it binds (a long alias quoted as errors quote a long word)."""
    ast = parse_condition(text)
    bound = bound_aliases(ast)
    warnings = []
    for alias, (line, column) in unbound_aliases(ast):
        close = difflib.get_close_matches(alias, bound, n=1, cutoff=0.6)
        message = (
            f"{alias} is bound by no CLASS clause of this condition: it has a value only where"
            " another rule bound it in scope U" + (f" (did you mean {close[0]}?)" if close else "")
        )
        placed = LocatedError(message, source=f"<condition {number}>", line=line, column=column)
        warnings.append(str(placed))
    return tuple(warnings)


def condition_error(text: str, toolkit: Toolkit | None = None) -> LocatedError | None:
    """Why ``text`` does not compile (placed in ``text``), or None when it does."""
    functions: FunctionRegistry | None = None if toolkit is None else toolkit.registries.functions
    try:
        compile_condition(text, registry=functions)
    except LocatedError as error:
        return error
    return None
