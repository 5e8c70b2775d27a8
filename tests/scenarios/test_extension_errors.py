"""An extension's registration errors name the extension (its file) and the culprit once:
a rule's ``writes`` or ``condition_text``, a rule code clash, an unmarked function, a
generator without a name. None of them blames oimi's built-ins."""

from __future__ import annotations

from pathlib import Path

import pytest
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.extensions import ExtensionError, build_toolkit, load_extension
from oimi.scenarios.loader import load_scenario

HEADER = (
    "from oimi.pipeline.think.functions import evaluation\n"
    "from oimi.pipeline.think.rules import Rule\n"
    "from oimi.pipeline.operator.generator import BaseGenerator\n\n"
)


def extension(folder: Path, name: str, body: str) -> Path:
    path = folder / f"{name}.py"
    path.write_text(f'{HEADER}NAME = "{name}"\n\n{body}')
    return path


def refused(path: Path, *others: Path) -> ExtensionError:
    """The error loading ``others`` then ``path`` raises (registering or building)."""
    with pytest.raises(ExtensionError) as caught:
        build_toolkit([*(load_extension(str(p)) for p in others), load_extension(str(path))])
    error = caught.value
    assert error.source == str(path), "it points at the extension"
    assert "built-in" not in error.source and "0x" not in str(error)
    return error


def test_a_writes_naming_no_part_of_the_map_names_the_extension_and_the_class(
    tmp_path: Path,
) -> None:
    path = extension(
        tmp_path,
        "badwrites",
        'class W(Rule):\n    rulecode = 1005\n    writes = ("humans", "scriptinfos")\n\n'
        "def register(ext):\n    ext.rule(W)\n",
    )
    error = refused(path, extension(tmp_path, "fine", "def register(ext):\n    pass\n"))
    assert error.message == (
        "W.writes: ['scriptinfos'] are not parts of the map (extension 'badwrites' (badwrites.py))"
    ), "only the culprit is named, not every extension loaded"


def test_a_writes_given_as_a_str_is_refused_as_such(tmp_path: Path) -> None:
    path = extension(
        tmp_path,
        "writesstr",
        'class W(Rule):\n    rulecode = 1006\n    writes = "scriptinfo"\n\n'
        "def register(ext):\n    ext.rule(W)\n",
    )
    error = refused(path)
    assert error.message == (
        'W.writes must be a tuple of map parts, e.g. ("scriptinfo",), not the str'
        " 'scriptinfo' (extension 'writesstr' (writesstr.py))"
    )
    path.write_text(path.read_text().replace('"scriptinfo"', "('humans', 3)"))
    assert "not ('humans', 3)" in refused(path).message


def test_a_condition_calling_an_unknown_function_names_the_extension_and_the_class(
    tmp_path: Path,
) -> None:
    path = extension(
        tmp_path,
        "badcond",
        'class C(Rule):\n    rulecode = 1007\n    condition_text = "! {E: nonesuch (1)}"\n\n'
        "def register(ext):\n    ext.rule(C)\n",
    )
    error = refused(path)
    assert error.message.startswith("C.condition_text: ")
    assert error.message.endswith("unknown function 'nonesuch' (extension 'badcond' (badcond.py))")


def test_in_a_scenario_the_error_is_placed_at_its_extensions_and_names_the_file(
    tmp_path: Path,
) -> None:
    extension(
        tmp_path,
        "badcond",
        'class C(Rule):\n    rulecode = 1007\n    condition_text = "! {E: nonesuch (1)}"\n\n'
        "def register(ext):\n    ext.rule(C)\n",
    )
    scenario = tmp_path / "s.toml"
    scenario.write_text('name = "s"\nextensions = ["badcond.py"]\n')
    with pytest.raises(ScenarioError) as caught:
        load_scenario(scenario)
    assert str(caught.value).startswith(f"{scenario}:2:1: C.condition_text: ")
    assert "(extension 'badcond' (badcond.py))" in str(caught.value)


def test_a_condition_may_call_a_function_another_extension_adds_later(tmp_path: Path) -> None:
    """Conditions are checked once every extension has registered, not one by one."""
    uses = extension(
        tmp_path,
        "uses",
        'class U(Rule):\n    rulecode = 1008\n    condition_text = "! {E: theirs ()}"\n\n'
        "def register(ext):\n    ext.rule(U)\n",
    )
    adds = extension(
        tmp_path,
        "adds",
        '@evaluation("theirs")\ndef theirs(ctx) -> bool:\n    return True\n\n'
        "def register(ext):\n    ext.function(theirs)\n",
    )
    toolkit = build_toolkit([load_extension(str(uses)), load_extension(str(adds))])
    assert 1008 in toolkit.registries.rules


def test_a_rule_code_clash_names_the_culprit_once(tmp_path: Path) -> None:
    rule = "class Dup(Rule):\n    rulecode = 1001\n\ndef register(ext):\n    ext.rule(Dup)\n"
    first, second = extension(tmp_path, "first", rule), extension(tmp_path, "second", rule)
    error = refused(second, first)
    assert error.message == (
        "rule code 1001 of Dup (extension 'second' (second.py)) collides with"
        " Dup (extension 'first' (first.py))"
    )


def test_an_unmarked_function_is_named_by_its_qualified_name(tmp_path: Path) -> None:
    path = extension(
        tmp_path,
        "unmarked",
        "class Holder:\n    @staticmethod\n    def plain(ctx, x: float) -> bool:\n"
        "        return True\n\ndef register(ext):\n    ext.function(Holder.plain)\n",
    )
    with pytest.raises(ExtensionError) as caught:
        load_extension(str(path))
    assert "ValueError: Holder.plain is not marked with @boolean, @string or @evaluation" in str(
        caught.value
    )
    assert "<function" not in str(caught.value) and "0x" not in str(caught.value)


def test_a_generator_without_a_name_is_refused(tmp_path: Path) -> None:
    path = extension(
        tmp_path,
        "genempty",
        "class G(BaseGenerator):\n    def build(self, values):\n        return None\n\n"
        "def register(ext):\n    ext.generator(G)\n",
    )
    error = refused(path)
    assert error.message == (
        "generator G has no name: give it one (name = \"...\") (extension 'genempty' (genempty.py))"
    )


@pytest.mark.parametrize(
    ("call", "said"),
    [
        ('ext.behaviour("", object)', "a behaviour's name must be a non-empty str, not ''"),
        ('ext.behaviour("wobble", 3)', "behaviour 'wobble': int is not a class or function"),
    ],
)
def test_a_behaviour_without_a_name_or_a_factory_is_refused(
    tmp_path: Path, call: str, said: str
) -> None:
    path = extension(tmp_path, "behbad", f"def register(ext):\n    {call}\n")
    assert refused(path).message == f"{said} (extension 'behbad' (behbad.py))"


def test_a_failing_import_names_the_line_of_the_extension_that_failed(tmp_path: Path) -> None:
    package = tmp_path / "broken"
    package.mkdir()
    (package / "__init__.py").write_text("from .rules import X\n\n\ndef register(ext):\n    pass\n")
    (package / "rules.py").write_text("import os\nimport no_such_module_for_oimi\nX = 1\n")
    with pytest.raises(ExtensionError) as caught:
        load_extension(str(package))
    assert str(caught.value).endswith(
        "failed to import: ModuleNotFoundError: No module named 'no_such_module_for_oimi'"
        " (rules.py:2)"
    )


def test_a_register_that_fails_names_its_line_in_the_extension(tmp_path: Path) -> None:
    path = extension(
        tmp_path,
        "unmarked",
        "def f(ctx):\n    return True\n\ndef register(ext):\n    ext.function(f)\n",
    )
    with pytest.raises(ExtensionError) as caught:
        load_extension(str(path))
    assert str(caught.value).endswith(
        "register failed: ValueError: f is not marked with @boolean, @string or @evaluation"
        " (unmarked.py:11)"
    )


def test_a_generated_jump_calling_an_unknown_function_is_refused_at_the_activity(
    tmp_path: Path,
) -> None:
    """Its script would never load (the Block Reader compiles its jumps): the check says so
    at the activity, as it does for a script file's jump."""
    extension(
        tmp_path,
        "genjump",
        "from oimi.pipeline.operator.generators.build import ScriptBuilder\n\n"
        "class G(BaseGenerator):\n    name = 'jumpy'\n\n    def build(self, values):\n"
        "        b = ScriptBuilder(self.name)\n        b.goal('g')\n"
        "        b.jump('! {E: nearr (?THIS, 1)}', false='end')\n"
        "        b.terminus(label='end')\n        return b.build()\n\n"
        "def register(ext):\n    ext.generator(G)\n",
    )
    scenario = tmp_path / "s.toml"
    scenario.write_text(
        'name = "s"\nextensions = ["genjump.py"]\n\n[[activities]]\ngenerator = "jumpy"\n'
    )
    with pytest.raises(ScenarioError) as caught:
        load_scenario(scenario)
    assert str(caught.value).startswith(
        f"{scenario}:5:1: activities[0].generator: generator 'jumpy' made a script that does"
        " not load: the jump at goal0/act0/blk0: unknown function 'nearr'; did you mean 'near'?"
    )


def test_a_function_name_clash_names_where_each_function_is_defined(tmp_path: Path) -> None:
    body = "@evaluation('wavy')\ndef mine(ctx) -> bool:\n    return True\n\n"
    register = "def register(ext):\n    ext.function(mine)\n"
    first = extension(tmp_path, "first", body + register)
    second = extension(tmp_path, "second", body + register)
    error = refused(second, first)
    assert error.message.startswith(
        "function 'wavy' of extension 'second' (second.py) (in mine, second.py:7) collides with"
        " extension 'first' (first.py) (in mine, first.py:7)"
    )
    clash = extension(tmp_path, "builtin", body.replace("wavy", "touched") + register)
    assert "(in mine, builtin.py:7) collides with oimi (built-in)" in refused(clash).message
