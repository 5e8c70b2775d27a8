"""The rule condition language (thesis section 4.3), in the shape of its anchors.

Four modules, one per stage: ``condition_ast`` (typed nodes), ``condition_parse``
(lark grammar ``condition.lark`` → AST, with located errors), ``condition_compile``
(AST → closures, checked against a :class:`~pipeline.think.functions.FunctionRegistry`)
and ``condition_runtime`` (evaluating those closures on a map). This module gathers
their public names. The language itself is described in ``docs/condition-language.md``.
"""

from __future__ import annotations

from oimi.pipeline.think.condition_ast import CLASS_FIELDS, THIS, ConditionAst, Op, Scope
from oimi.pipeline.think.condition_compile import compile_condition
from oimi.pipeline.think.condition_parse import parse_condition
from oimi.pipeline.think.condition_runtime import (
    Condition,
    Evaluation,
    entity_ref,
    find_entity,
    release_alias,
)
from oimi.pipeline.think.errors import RuleSyntaxError

__all__ = [
    "CLASS_FIELDS",
    "THIS",
    "Condition",
    "ConditionAst",
    "Evaluation",
    "Op",
    "RuleSyntaxError",
    "Scope",
    "compile_condition",
    "entity_ref",
    "find_entity",
    "parse_condition",
    "release_alias",
]
