"""Property tests: any valid Script survives DSL and JSON round trips unchanged."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from oimi.pipeline.messages import (
    Action,
    AudioOut,
    Goal,
    InstructionBlock,
    JumpBlock,
    Led,
    Move,
    MutexCmd,
    RuleAction,
    RuleMessage,
    Script,
    SensorBlock,
    TerminusBlock,
)
from oimi.pipeline.script import (
    compile_dsl,
    dump_script_json,
    load_script_json,
    render_dsl,
    script_errors,
)
from oimi.pipeline.script.validate import block_path

TEXT = st.text(st.characters(blacklist_categories=("Cs",)), max_size=12)
NAME = TEXT.filter(bool)
SPEED = st.floats(-100, 100, allow_nan=False).map(lambda x: round(x, 3))
COLOUR = st.floats(0, 1).map(lambda x: round(x, 3))
MS = st.integers(0, 10**7)
CONDITION_TEXT = st.text(
    st.characters(blacklist_categories=("Cs", "Cc"), blacklist_characters='()"[]'), min_size=1
).filter(str.strip)
CONDITIONS = st.one_of(
    st.sampled_from(
        [
            "! {TRUE}",
            "{TRUE}",
            ' ! {E: near (?child, "1.5")} ',
            '{CLASS #Human U ?child (?THIS>&positionrho < "1.0")} ! {E: seen (?child, ")(")}',
            "! {E: f ((a), (b ()))}",
        ]
    ),
    CONDITION_TEXT,
)

moves = st.builds(Move, v_x=SPEED, v_y=SPEED, v_theta=SPEED, wait_t=MS, duration=MS)
leds = st.builds(
    Led, r=COLOUR, g=COLOUR, b=COLOUR, turnas=st.sampled_from([0, 1]), wait_t=MS, duration=MS
)
audios = st.builds(AudioOut, track_path=TEXT.map(str.strip), wait_t=MS, duration=MS)
instructions = st.builds(
    InstructionBlock,
    move=st.lists(moves, max_size=3).map(tuple),
    led=st.lists(leds, max_size=3).map(tuple),
    audioout=st.lists(audios, max_size=2).map(tuple),
    flagged=st.none() | TEXT,
)


def rule_messages(*, alfa: bool):
    def build(items: list[tuple[int, str, str, str, RuleAction]]) -> tuple[RuleMessage, ...]:
        out = []
        for i, (code, ident, intopic, outtopic, action) in enumerate(items):
            if alfa:
                mutex = MutexCmd.U if i == len(items) - 1 else MutexCmd.M
            else:
                mutex = MutexCmd.L if i == 0 else MutexCmd.M
            out.append(
                RuleMessage(
                    rulecode=code,
                    id=ident,
                    intopic=intopic,
                    outtopic=outtopic,
                    action=action,
                    mutexcmd=mutex,
                )
            )
        return tuple(out)

    item = st.tuples(st.integers(0, 999), NAME, TEXT, TEXT, st.sampled_from(list(RuleAction)))
    return st.lists(item, max_size=3).map(build)


@st.composite
def scripts(draw) -> Script:
    shape = draw(
        st.lists(st.lists(st.integers(1, 3), min_size=1, max_size=2), min_size=1, max_size=2)
    )
    paths = [
        block_path(g, a, b)
        for g, actions in enumerate(shape)
        for a, count in enumerate(actions)
        for b in range(count)
    ]
    targets = st.sampled_from(["", *paths])
    jumps = st.builds(JumpBlock, toparse=CONDITIONS, truejump=targets, falsejump=targets)
    sensors = st.builds(SensorBlock, request=TEXT)
    block = st.one_of(instructions, jumps, st.just(TerminusBlock()), sensors)
    goals = tuple(
        Goal(
            goalid=draw(NAME),
            actions=tuple(
                Action(blocks=tuple(draw(block) for _ in range(count))) for count in actions
            ),
        )
        for actions in shape
    )
    return Script(
        activityname=draw(NAME),
        alfarulemessages=draw(rule_messages(alfa=True)),
        omegarulemessages=draw(rule_messages(alfa=False)),
        goals=goals,
    )


@settings(max_examples=80, deadline=None)
@given(scripts())
def test_any_valid_script_survives_render_and_compile(script):
    assert script_errors(script) == []
    assert compile_dsl(render_dsl(script), source="<rendered>") == script


@settings(max_examples=80, deadline=None)
@given(scripts())
def test_any_valid_script_survives_json_dump_and_load(script):
    assert load_script_json(dump_script_json(script), source="<dumped>") == script
