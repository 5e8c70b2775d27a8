"""Scripts: the thesis's JSON format, the text DSL compiler, validation and rendering.

See ``docs/script-language.md`` for the language reference.
"""

from pipeline.script.dsl import compile_dsl, parse_dsl
from pipeline.script.errors import ScriptError
from pipeline.script.files import parse_script
from pipeline.script.json_format import dump_script_json, load_script_json, parse_script_json
from pipeline.script.render import render_dsl
from pipeline.script.sourcemap import ParsedScript, SourceMap, decode_text
from pipeline.script.validate import condition_errors, script_errors, validate_script

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
