"""Which format a script file is in, from its name: ``.json`` is JSON, anything else DSL."""

from __future__ import annotations

from oimi.pipeline.script.dsl import parse_dsl
from oimi.pipeline.script.json_format import parse_script_json
from oimi.pipeline.script.sourcemap import ParsedScript


def is_json_name(source: str) -> bool:
    return source.lower().endswith(".json")


def parse_script(data: str | bytes, *, source: str) -> ParsedScript:
    """The script in a file's content (JSON for ``*.json``, the DSL otherwise), with positions."""
    if is_json_name(source):
        return parse_script_json(data, source=source)
    return parse_dsl(data, source=source)
