"""Cython declarations that compile a module's busiest classes to extension types.

An extension type keeps its instances' attributes in a C struct: a method reads and writes
``self``'s attributes directly instead of through a dictionary (about a tenth of a
session's time went to attribute lookups). The declarations are derived from the source
when it is compiled, so they cannot drift from it: each listed class declares, as a public
Python object, every attribute its methods assign on ``self``. Python never reads them.
"""

from __future__ import annotations

import ast
from collections.abc import Sequence


class DeclarationError(ValueError):
    """A class cannot be made an extension type (not found, or a base that is not one)."""


def declarations(source: str, classes: Sequence[str], *, filename: str = "<source>") -> str:
    """The ``.pxd`` text declaring ``classes`` of ``source`` as extension types (a base
    class must be one of ``classes`` too, listed before it; an attribute a base declares is
    not declared again)."""
    tree = ast.parse(source, filename)
    found = {node.name: node for node in tree.body if isinstance(node, ast.ClassDef)}
    declared: dict[str, set[str]] = {}
    lines: list[str] = []
    for name in classes:
        node = found.get(name)
        if node is None:
            raise DeclarationError(f"{filename}: no class {name} at the top of the module")
        bases = [ast.unparse(base) for base in node.bases]
        if len(bases) > 1 or (bases and bases[0] not in declared) or node.keywords:
            raise DeclarationError(
                f"{filename}:{node.lineno}: class {name}({', '.join(bases)}): an extension"
                " type derives from at most one class, itself listed before it"
            )
        inherited = declared[bases[0]] if bases else set()
        own = [a for a in assigned_attributes(node) if a not in inherited]
        declared[name] = inherited | set(own)
        lines.append(f"cdef class {name}({bases[0]}):" if bases else f"cdef class {name}:")
        lines.append(f"    cdef public object {', '.join(own)}" if own else "    pass")
    return "\n".join(lines) + "\n"


def assigned_attributes(node: ast.ClassDef) -> list[str]:
    """The attributes the class's methods assign on ``self`` (``self.x = ...``, also in a
    tuple of targets; not ``self.x[i] = ...`` nor ``self.x.y = ...``), in the order first
    assigned."""
    names: dict[str, None] = {}
    for statement in ast.walk(node):
        if isinstance(statement, ast.Assign):
            targets = list(statement.targets)
        elif isinstance(statement, ast.AnnAssign | ast.AugAssign):
            targets = [statement.target]
        else:
            continue
        while targets:
            target = targets.pop(0)
            if isinstance(target, ast.Tuple | ast.List):
                targets[:0] = target.elts
            elif isinstance(target, ast.Starred):
                targets.insert(0, target.value)
            elif (
                isinstance(target, ast.Attribute)
                and isinstance(target.value, ast.Name)
                and target.value.id == "self"
            ):
                names.setdefault(target.attr)
    return list(names)
