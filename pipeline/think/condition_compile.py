"""Compiling a condition's AST to closures, checked against a function registry.

``compile_condition(text, registry=...)`` parses once, checks every class, field,
operator and function, and builds the steps a :class:`Condition` runs, with what they
read (:attr:`Condition.reads`: the map fields, the clock, the alias and variable stores).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Final

from oimi.pipeline.errors import defined_at
from oimi.pipeline.texts import did_you_mean
from oimi.pipeline.think.condition_ast import (
    ALL_FIELDS,
    CLASS_FIELDS,
    THIS,
    AliasRef,
    AttRef,
    Call,
    ClassClause,
    Clause,
    Criterion,
    EvalClause,
    FieldRef,
    Literal,
    Operand,
    Scope,
    TrueClause,
    VarClause,
    VarRef,
    located,
)
from oimi.pipeline.think.condition_parse import (
    parse_condition,
)
from oimi.pipeline.think.condition_runtime import (
    ENTITY_READS,
    FAIL,
    GO,
    MISSING,
    NUMBER_OPS,
    STORE_READS,
    TRUE,
    Condition,
    Getter,
    Run,
    Step,
    compare,
    entities_of,
    entity_ref,
    find_entity,
    to_number,
    to_text,
)
from oimi.pipeline.think.functions import (
    ArgKind,
    Bound,
    Family,
    FunctionRegistry,
    FunctionSpec,
)
from oimi.pipeline.think.stdlib import default_registry

_L = Scope.L


class _Compiler:
    def __init__(self, registry: FunctionRegistry):
        self.registry = registry
        self.reads: set[str] | None = set()
        """What the steps compiled so far read (``None``: a function that may read anything)."""
        self.alias_classes: dict[str, str] = {}
        """The class each alias has once the CLASS clauses compiled so far succeeded."""
        self.binds = False
        """Whether a clause compiled so far writes scope U or T (a store of the map's, or
        the tick scope)."""

    def read(self, *paths: str) -> None:
        if self.reads is not None:
            self.reads.update(paths)

    def read_alias(self, alias: str) -> None:
        """An alias looked up in the stores, and its entity in its class's list (in any
        entity list when no earlier CLASS clause fixed its class)."""
        cls = self.alias_classes.get(alias)
        self.read(*STORE_READS, *((ENTITY_READS[cls],) if cls else ENTITY_READS.values()))

    # operands ---------------------------------------------------------------------

    def field_type(self, ref: FieldRef, this_cls: str | None) -> type | None:
        if ref.alias == THIS:
            assert this_cls is not None
            fields = CLASS_FIELDS[this_cls]
            if ref.field not in fields:
                raise located(
                    f"unknown field '&{ref.field}' of #{this_cls} (fields: {', '.join(fields)})",
                    ref.pos,
                )
            return fields[ref.field]
        if ref.field not in ALL_FIELDS:
            raise located(
                f"unknown field '&{ref.field}'{did_you_mean(ref.field, ALL_FIELDS)}", ref.pos
            )
        return None

    def operand(
        self,
        node: Operand,
        this_cls: str | None,
        kind: ArgKind = ArgKind.ANY,
        accepts: tuple[type, ...] = (),
    ) -> Getter:
        alias = getattr(node, "alias", None)
        if alias == THIS and this_cls is None:
            raise located("?THIS can only be used inside a CLASS clause", node.pos)
        if isinstance(node, AliasRef):
            if kind not in (ArgKind.ENTITY, ArgKind.OPTIONAL_ENTITY):
                raise located(f"expected {kind.value} here, got the alias {node.alias}", node.pos)
            optional = kind is ArgKind.OPTIONAL_ENTITY
            accepted = accepts or (object,)
            if node.alias == THIS:
                return lambda run, this: this if isinstance(this, accepted) else MISSING
            self.read_alias(node.alias)

            def entity(run: Run, this: Bound | None, _a: str = node.alias) -> object:
                found = run.entity(_a)
                if found is None:
                    return None if optional else MISSING
                return found if isinstance(found, accepted) else MISSING

            return entity
        if kind in (ArgKind.ENTITY, ArgKind.OPTIONAL_ENTITY):
            raise located(f"expected {kind.value} here", node.pos)
        getter = self.value(node, this_cls)
        if kind is ArgKind.NUMBER:
            if isinstance(node, Literal) and isinstance(node.value, str):
                raise located(f"expected a number here, got {node.text!r}", node.pos)
            return lambda run, this: to_number(getter(run, this))
        if kind is ArgKind.TEXT:
            if isinstance(node, Literal):
                text = node.text
                return lambda run, this: text
            return lambda run, this: to_text(getter(run, this))
        return getter

    def value(self, node: Operand, this_cls: str | None) -> Getter:
        if isinstance(node, Literal):
            value = node.value
            return lambda run, this: value
        if isinstance(node, FieldRef):
            self.field_type(node, this_cls)
            field = node.field
            if node.alias == THIS:
                return lambda run, this: getattr(this, field)
            self.read_alias(node.alias)

            def other_field(run: Run, this: Bound | None, _a: str = node.alias) -> object:
                return getattr(run.entity(_a), field, MISSING)

            return other_field
        if isinstance(node, AttRef):
            att = node.att
            if node.alias == THIS:

                def this_att(run: Run, this: Bound | None) -> object:
                    attributes = getattr(this, "attributes", None) or {}
                    return attributes.get(att, MISSING)

                return this_att
            self.read_alias(node.alias)
            return lambda run, this, _a=node.alias: run.attribute(_a, att)
        if isinstance(node, VarRef):
            name = node.name
            self.read(*STORE_READS)

            def variable(run: Run, this: Bound | None) -> object:
                value = run.variable(name)
                return MISSING if value is None else value

            return variable
        raise located(
            f"compare with {node.alias}>&field or {node.alias}>$attribute, not a bare alias",
            node.pos,
        )

    # calls ------------------------------------------------------------------------

    def call(self, call: Call, family: Family, this_cls: str | None = None) -> Getter:
        where = {
            Family.B: "a CLASS criterion takes a B: function",
            Family.F: "a VAR or ATT clause takes an F: function",
            Family.E: "an evaluation clause takes an E: function",
        }[family]
        if call.family != family:
            raise located(f"{where}, not {call.family}:", call.family_pos)
        spec = self.registry.get(call.name)
        if spec is None:
            raise located(
                f"unknown function {call.name!r}{did_you_mean(call.name, self.registry.names())}",
                call.name_pos,
            )
        if spec.family is not family:
            raise located(
                f"{call.name!r} is a {spec.family}: function, not {family}: ({where})",
                call.name_pos,
            )
        count = len(call.args)
        if count < spec.min_args or (spec.max_args is not None and count > spec.max_args):
            raise located(
                f"{call.name!r} takes {spec.arity_text()} argument(s), got {count}:"
                f" {spec.signature}",
                call.name_pos,
            )
        if family is Family.B and this_cls not in spec.classes:
            only = ", ".join(f"#{c}" for c in spec.classes)
            raise located(
                f"{call.name!r} does not apply to #{this_cls} (only {only})", call.name_pos
            )
        if spec.reads is None:
            self.reads = None
        else:
            self.read(*spec.reads)
        getters = tuple(
            self.operand(arg, this_cls, spec.kind(i), spec.accepts(i))
            for i, arg in enumerate(call.args)
        )
        if all(isinstance(arg, Literal) for arg in call.args):
            # literal arguments are the same at every call: gather them once
            args = tuple(get(None, None) for get in getters)  # type: ignore[arg-type]
            if MISSING not in args:
                return _bind_constant_call(spec, args)
        return _bind_call(spec, getters)

    # clauses ----------------------------------------------------------------------

    def criterion(self, node: Criterion, cls: str) -> Callable[[Run, Bound], bool]:
        if isinstance(node, Call):
            return _truth(self.call(node, Family.B, cls), self.registry.get(node.name))
        left = node.left
        if not (isinstance(left, FieldRef) and left.alias == THIS):
            raise located("the left of a comparison must be ?THIS>&field", left.pos)
        self.field_type(left, cls)
        field = left.field
        op = node.op
        literal = node.right.value if isinstance(node.right, Literal) else None
        if isinstance(literal, int | float) and not isinstance(literal, bool):
            # The common ``?THIS>&positionrho OP< 0.8``: a number field against a number
            # needs none of compare's casts, so compare at once (others take compare).
            number_op = NUMBER_OPS[op]

            def number_criterion(run: Run, this: Bound) -> bool:
                value = getattr(this, field)
                if type(value) is float or type(value) is int:
                    return number_op(value, literal)
                return compare(value, op, literal)

            return number_criterion
        right = self.value(node.right, cls)
        return lambda run, this: compare(getattr(this, field), op, right(run, this))

    def clause(self, node: Clause, left_side: bool) -> Step:
        if isinstance(node, TrueClause):
            return lambda run: TRUE
        if left_side and isinstance(node, EvalClause):
            raise located("E: evaluations belong after '!'", node.pos)
        if not left_side and not isinstance(node, EvalClause):
            raise located("assignments (CLASS, VAR, ATT) belong before '!'", node.pos)
        if isinstance(node, EvalClause):
            holds = _truth(self.call(node.call, Family.E), self.registry.get(node.call.name))
            return lambda run: GO if holds(run, None) else FAIL
        self.binds |= node.scope is not _L  # a CLASS, VAR or ATT clause: stored there
        if isinstance(node, ClassClause):
            self.read(*STORE_READS, ENTITY_READS[node.cls])
            criteria = tuple(self.criterion(c, node.cls) for c in node.criteria)
            self.alias_classes[node.alias] = node.cls
            return _class_step(node, criteria)
        self.read(*STORE_READS)
        if isinstance(node, VarClause):
            return _assign_step(node.var, node.scope, self.call(node.call, Family.F), None)
        self.read_alias(node.alias)
        call = self.call(node.call, Family.F)
        return _assign_step(f"{node.alias}${node.att}", node.scope, call, node.alias)


def _truth(call: Getter, spec: FunctionSpec | None) -> Callable[[Run, Bound | None], bool]:
    """A B or E call's truth: ``True`` or ``False`` (a missing argument: ``False``); any
    other result is the function's mistake, raised as a ``TypeError`` naming it and where
    it is defined (``child_near returned 2.5, not True or False (in child_near,
    functions.py:9)``)."""
    assert spec is not None  # the call was compiled: its function is registered
    name, where = spec.name, defined_at(spec.fn)
    place = f" ({where})" if where else ""

    def holds(run: Run, this: Bound | None) -> bool:
        found = call(run, this)
        if found is True:
            return True
        if found is False or found is MISSING:
            return False
        raise TypeError(f"{name} returned {found!r:.60}, not True or False{place}")

    return holds


def _bind_constant_call(spec: FunctionSpec, args: tuple[object, ...]) -> Getter:
    """A call whose arguments are all literals (``B: closer_than (2.0)``) or none."""
    fn = spec.fn
    if spec.family is Family.B:
        return lambda run, this: fn(run.ctx, this, *args)
    return lambda run, this: fn(run.ctx, *args)


def _bind_call(spec: FunctionSpec, getters: tuple[Getter, ...]) -> Getter:
    fn = spec.fn
    with_entity = spec.family is Family.B

    def run_call(run: Run, this: Bound | None) -> object:
        args = []
        for get in getters:
            value = get(run, this)
            if value is MISSING:
                return MISSING
            args.append(value)
        if with_entity:
            return fn(run.ctx, this, *args)
        return fn(run.ctx, *args)

    return run_call


def _class_step(node: ClassClause, criteria: tuple[Callable[[Run, Bound], bool], ...]) -> Step:
    cls, alias, scope = node.cls, node.alias, node.scope

    def meets(run: Run, entity: Bound) -> bool:
        for criterion in criteria:  # noqa: SIM110 (a plain loop: all() over a generator costs more)
            if not criterion(run, entity):
                return False
        return True

    def step(run: Run) -> int:
        own = run.alias_store(scope)  # a binding of this name in another scope is not ours
        ref = own.get(alias)
        if ref is not None:  # thesis 4.3: bound until its scope ends (or a rule frees it)
            if not ref.startswith(cls + "/"):
                return FAIL  # another class's entity (its list is not this clause's to read)
            entity = find_entity(run.world_map, ref)
            if entity is not None:
                if not meets(run, entity):
                    return FAIL
                run.bindings[alias] = ref
                return GO
            run.unbind_alias(alias, scope)  # its entity left the map: chosen again
        taken = run.taken(alias)
        best: Bound | None = None
        for entity in entities_of(run.world_map, cls):
            if best is not None and entity.creationtime >= best.creationtime:
                continue
            if taken and entity_ref(cls, entity) in taken:  # no ref to build when none is
                continue
            if not meets(run, entity):
                continue
            best = entity
        if best is None:
            return FAIL
        ref = entity_ref(cls, best)
        own[alias] = ref
        run.bindings[alias] = ref
        return GO

    return step


def _assign_step(key: str, scope: Scope, call: Getter, alias: str | None) -> Step:
    def step(run: Run) -> int:
        if alias is not None and run.entity(alias) is None:
            return FAIL
        value = call(run, None)
        text = MISSING if value is None or value is MISSING else to_text(value)
        if text is MISSING:
            return FAIL
        assert isinstance(text, str)
        run.store(scope)[key] = text
        run.bindings[key] = text
        return GO

    return step


def compile_condition(text: str, *, registry: FunctionRegistry | None = None) -> Condition:
    """Parse, check and compile ``text``; raises :class:`RuleSyntaxError` (``<condition>:L:C``).

    Compiled once per registry and text (a script's alfa messages create rules again each
    time it loads): a :class:`Condition` holds no state of its own, so rules share it."""
    registry = registry or default_registry()
    compiled = registry.conditions.get(text)
    if compiled is None:
        compiled = _compile(text, registry)
        if len(registry.conditions) >= _CACHED:  # (texts made at run time: keep it bounded)
            registry.conditions.clear()
        registry.conditions[text] = compiled
    return compiled


_CACHED: Final = 1024
"""The most conditions a registry keeps compiled."""


def _compile(text: str, registry: FunctionRegistry) -> Condition:
    ast = parse_condition(text)
    if not ast.has_bang:
        if ast.left and isinstance(ast.left[0], TrueClause) and len(ast.left) == 1:
            return Condition(text, (lambda run: TRUE,), (), registry.version, reads=(), binds=False)
        if not ast.left:
            raise located("empty condition", (1, 1))
        first_eval = next((c for c in ast.left if isinstance(c, EvalClause)), None)
        pos = first_eval.pos if first_eval is not None else ast.end_pos
        raise located(
            "missing '!' between the assignments and the evaluations"
            " (only {TRUE} stands without '!')",
            pos,
        )
    compiler = _Compiler(registry)
    steps = tuple(compiler.clause(c, True) for c in ast.left)
    steps += tuple(compiler.clause(c, False) for c in ast.right)
    aliases = tuple(c.alias for c in ast.left if isinstance(c, ClassClause))
    reads = None if compiler.reads is None else tuple(sorted(compiler.reads))
    return Condition(text, steps, aliases, registry.version, reads=reads, binds=compiler.binds)
