"""The generator protocol: option specs, option validation, lifecycle, the catalogue."""

from __future__ import annotations

import msgspec
import pytest
from oimi.pipeline.errors import LocatedError
from oimi.pipeline.messages import Script
from oimi.pipeline.operator.generator import (
    Catalogue,
    GeneratorError,
    GeneratorInfo,
    OptionKind,
    OptionSpec,
    parse_options,
    resolve_options,
)
from oimi.pipeline.operator.generators import (
    BlinkGenerator,
    DanceGenerator,
    StaticScriptGenerator,
    default_catalogue,
)

TEMPO = OptionSpec(
    name="tempo",
    kind=OptionKind.CHOICE,
    default="medium",
    choices=("slow", "medium", "fast"),
    min=40,
    max=160,
)
REPS = OptionSpec(name="reps", kind=OptionKind.NUMBER, default="2", min=1, max=10, integer=True)
COLOURS = OptionSpec(name="colours", kind=OptionKind.COLOUR, default="red", multiple=True)
TRACK = OptionSpec(name="track", kind=OptionKind.TEXT, default="song.wav")
SPECS = (TEMPO, REPS, COLOURS, TRACK)


def test_choice_accepts_a_choice_or_a_number_in_range():
    assert TEMPO.parse("fast") == "fast"
    assert TEMPO.parse("100") == 100.0


@pytest.mark.parametrize(
    ("spec", "text", "message"),
    [
        (
            TEMPO,
            "lively",
            r"option 'tempo': 'lively' is not one of slow, medium, fast or a "
            r"number in 40\.\.160",
        ),
        (TEMPO, "200", r"option 'tempo': '200' is not one of"),
        (REPS, "0", r"option 'reps': 0 is out of range 1\.\.10"),
        (REPS, "2.5", r"option 'reps': '2.5' is not a whole number"),
        (REPS, "many", r"option 'reps': 'many' is not a whole number in 1\.\.10"),
        (REPS, "nan", r"option 'reps': 'nan' is not a finite number"),
        (COLOURS, "red,,blue", r"option 'colours': 'red,,blue' is not a comma-separated list"),
        (COLOURS, "red,mauve", r"option 'colours': 'mauve' is not a colour \(red, green"),
        (COLOURS, "#12345g", r"'#12345g' is not a colour"),
        (TRACK, "  ", r"option 'track': must not be empty"),
    ],
)
def test_bad_option_text_is_refused_naming_the_option(spec, text, message):
    with pytest.raises(GeneratorError, match=message) as info:
        spec.parse(text, source="dance")
    assert info.value.option == spec.name
    assert str(info.value).startswith("dance: option ")


def test_colours_parse_names_and_hex_into_unit_rgb():
    assert COLOURS.parse("Blue, #ff8000") == ((0.0, 0.0, 1.0), (1.0, 0.502, 0.0))


def test_resolve_options_fills_defaults_in_spec_order():
    resolved = resolve_options(SPECS, {"track": "x.wav", "tempo": "slow"})
    assert list(resolved.items()) == [
        ("tempo", "slow"),
        ("reps", "2"),
        ("colours", "red"),
        ("track", "x.wav"),
    ]


def test_unknown_option_is_refused_listing_the_known_ones():
    with pytest.raises(GeneratorError, match=r"unknown option 'speed' \(options: tempo, reps"):
        resolve_options(SPECS, {"speed": "3"}, source="dance")


def test_parse_options_types_every_value():
    values = parse_options(SPECS, {"reps": "3"})
    assert values == {
        "tempo": "medium",
        "reps": 3,
        "colours": ((1.0, 0.0, 0.0),),
        "track": "song.wav",
    }


def test_generator_error_is_a_located_error():
    assert issubclass(GeneratorError, LocatedError)


def test_generator_is_quiescent_until_activated():
    g = BlinkGenerator()
    with pytest.raises(GeneratorError, match="generate called before activate"):
        g.generate()
    g.activate({})
    assert g.generate().activityname == "example_act"
    g.shutdown()
    with pytest.raises(GeneratorError, match="before activate"):
        g.generate()


def test_activate_with_bad_options_leaves_the_generator_quiescent():
    g = DanceGenerator()
    with pytest.raises(GeneratorError, match="option 'repetitions'"):
        g.activate({"repetitions": "0"})
    assert not g.active


def test_static_generator_hands_out_its_script_and_takes_no_options():
    script = Script(activityname="from_file")
    g = StaticScriptGenerator("file_act", script)
    with pytest.raises(GeneratorError, match=r"unknown option 'x' \(options: none\)"):
        g.activate({"x": "1"})
    g.activate({})
    assert g.generate() is script


def test_catalogue_gives_a_fresh_instance_per_selection():
    cat = default_catalogue()
    assert cat.create("test_dance") is not cat.create("test_dance")


def test_catalogue_describes_every_generator_with_its_options():
    cat = default_catalogue({"file_act": Script(activityname="from_file")})
    infos = cat.describe()
    assert [i.name for i in infos] == [
        "test_dance",
        "greeting",
        "joint_attention",
        "example_act",
        "file_act",
    ]
    dance = infos[0]
    assert [o.name for o in dance.options] == ["tempo", "colours", "repetitions", "track", "seed"]
    decoded = msgspec.json.decode(cat.describe_json(), type=tuple[GeneratorInfo, ...])
    assert decoded == infos


def test_catalogue_refuses_a_key_that_does_not_match_the_generator_name():
    with pytest.raises(GeneratorError, match="catalogue key 'dance' makes a generator named"):
        Catalogue({"dance": DanceGenerator})


def test_catalogue_refuses_a_repeated_name():
    with pytest.raises(GeneratorError, match="already in the catalogue"):
        default_catalogue({"greeting": Script(activityname="g")})
