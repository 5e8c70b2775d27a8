"""Scripts: the thesis's JSON format, the text DSL compiler, validation and rendering.

See ``docs/script-language.md`` for the language reference.
"""

from oimi.pipeline.script.dsl import compile_dsl, parse_dsl
from oimi.pipeline.script.errors import ScriptError
from oimi.pipeline.script.files import parse_script
from oimi.pipeline.script.json_format import dump_script_json, load_script_json, parse_script_json
from oimi.pipeline.script.render import render_dsl
from oimi.pipeline.script.sourcemap import ParsedScript, SourceMap, decode_text
from oimi.pipeline.script.validate import condition_errors, script_errors, validate_script

__all__ = [
    "ParsedScript",
    "ScriptError",
    "SourceMap",
    "compile_dsl",
    "condition_errors",
    "decode_text",
    "dump_script_json",
    "load_script_json",
    "parse_dsl",
    "parse_script",
    "parse_script_json",
    "render_dsl",
    "script_errors",
    "validate_script",
]
