"""What the Rerun view says in words: the block now, a line per channel and never with
another place's; the text tabs up to the time cursor; the Rules tab without letters or
raw JSON; the Sound tab's tracks by their file."""

from __future__ import annotations

from pathlib import Path

import msgspec
import pytest
from oimi.pipeline.events import (
    ActuatorCommands,
    Event,
    Level,
    LogEntries,
    LogEntry,
    MapChange,
    ReaderProgress,
    RuleDecision,
    RuleDecisions,
    Topic,
)
from oimi.pipeline.messages import AudioOut, InstructionBlock, Led, Move, RuleMessage
from oimi.recorder.rerun_sink import (
    RECENT_LINES,
    RerunSink,
    block_lines,
    chain_words,
    default_blueprint,
    value_words,
)
from recorder_synthetic import SCENE, rows, session, views, world_state


@pytest.mark.parametrize(
    ("block", "lines"),
    [
        (
            InstructionBlock(
                move=(Move(v_x=0.15, v_y=0.0, v_theta=0.0, wait_t=0, duration=2000),),
                led=(Led(r=1.0, g=1.0, b=0.0, turnas=1, wait_t=0, duration=2000),),
                audioout=(AudioOut(track_path="audio/hello.wav", wait_t=0, duration=900),),
            ),
            ["MV 0.15 m/s for 2.0 s", "LED yellow", "sound hello.wav"],
        ),
        (
            InstructionBlock(
                move=(
                    Move(v_x=0.0, v_y=0.0, v_theta=0.5, wait_t=500, duration=1000),
                    Move(v_x=0.0, v_y=0.0, v_theta=0.0, wait_t=0, duration=1000),
                ),
                led=(
                    Led(r=1.0, g=1.0, b=1.0, turnas=0, wait_t=0, duration=0),
                    *[Led(r=0.0, g=0.0, b=0.4, turnas=1, wait_t=0, duration=200)] * 3,
                    Led(r=1.0, g=1.0, b=1.0, turnas=0, wait_t=0, duration=0),
                ),
            ),
            [
                "MV turn 0.50 rad/s for 1.0 s after 0.5 s → stand still for 1.0 s",
                "LED off → dim blue ×3 → off",
            ],
        ),
        (InstructionBlock(), ["nothing"]),
    ],
)
def test_the_current_block_reads_as_a_line_per_channel(
    block: InstructionBlock, lines: list[str]
) -> None:
    """A line per channel, a run of one colour said once: one heading-sized line was cut
    at the pane's edge at 1280x800."""
    assert block_lines(block) == lines


def test_the_now_pane_lists_the_blocks_channels_at_body_size(tmp_path: Path) -> None:
    path = tmp_path / "now.rrd"
    with RerunSink(path, recording_id="now", scene=SCENE) as sink:
        for topic, time_ns, event in session(2):
            sink.record(topic, time_ns, event)
    last = max(rows(path, "/script/block"), key=lambda row: row["tick"])
    text = last["TextDocument:text"][0]
    assert "#" not in text
    assert text.splitlines() == ["**greet** · goal0/act0/blk0", "", "- MV 0.60 m/s for 1.0 s"]


def test_the_now_pane_never_names_a_place_with_the_blocks_of_another(tmp_path: Path) -> None:
    """The Block Reader names the new place a tick before the actuator starts its block:
    until then the place is shown alone (it was shown with the old block's words)."""
    red, green = (
        InstructionBlock(led=(Led(r=r, g=g, b=0.0, turnas=1, wait_t=0, duration=1000),))
        for r, g in ((1.0, 0.0), (0.0, 1.0))
    )

    def at(tick: int, blk: str, block: InstructionBlock | None) -> list[tuple[Topic, Event]]:
        t = {"tick": tick, "time_ms": tick * 20}
        place = {"activity": "play", "goalid": "goal0", "actionid": "act0", "blockid": blk}
        commands = ActuatorCommands(**t, commands=(), block=block)
        return [
            (Topic.ACTUATOR_COMMANDS, commands),
            (Topic.READER_PROGRESS, ReaderProgress(**t, **place)),
        ]

    path = tmp_path / "now.rrd"
    with RerunSink(path, recording_id="now", scene=SCENE) as sink:
        for topic, event in [
            *at(0, "blk0", None),
            *at(1, "blk0", red),
            *at(5, "blk1", red),
            *at(6, "blk1", green),
        ]:
            sink.record(topic, event.tick * 20_000_000, event)
    shown = {row["tick"]: row["TextDocument:text"][0] for row in rows(path, "/script/block")}
    assert shown[1].splitlines()[::2] == ["**play** · goal0/act0/blk0", "- LED red"]
    assert shown[5] == "**play** · goal0/act0/blk1"  # the last at tick 5
    assert shown[6].splitlines()[::2] == ["**play** · goal0/act0/blk1", "- LED green"]


def test_the_rules_pane_says_what_each_alfa_omega_message_did_in_words(tmp_path: Path) -> None:
    """One letter (``A avoid``) told a designer little: the action is said in words."""
    rrd = tmp_path / "chain.rrd"
    with RerunSink(rrd, recording_id="chain", scene=SCENE) as sink:
        for topic, time_ns, event in session(2):
            sink.record(topic, time_ns, event)
    said = [row["TextLog:text"][0].split("  ")[-1] for row in rows(rrd, "/rules/chain")]
    assert said[0] == "added avoid; active: avoid"
    assert said[1] == "added avoid; active: avoid (map locked)"


def test_a_rule_firing_evaluation_after_evaluation_is_said_when_something_changes(
    tmp_path: Path,
) -> None:
    """A condition that holds fired at every evaluation: the same line ten times a second
    filled the Rules tab. A firing is said when it starts, changes its bindings or the
    map, and when it stops."""
    ben, ada = {"?child": "Human/ben"}, {"?child": "Human/ada"}
    change = (MapChange(path="scriptinfo.changed", old="false", new="true"),)
    evaluations = [(ben, ()), (ben, ()), (ben, change), (ben, ()), (ada, ()), (None, ())]
    path = tmp_path / "rules.rrd"
    with RerunSink(path, recording_id="rules", scene=SCENE) as sink:
        for tick, (bindings, changes) in enumerate(evaluations):
            fired = bindings is not None
            decision = RuleDecision(
                rule="lost", rulecode=4, fired=fired, bindings=bindings or {}, changes=changes
            )
            event = RuleDecisions(tick=tick, time_ms=tick * 20, decisions=(decision,))
            sink.record(Topic.RULE_DECISIONS, tick * 20_000_000, event)
    said = sorted((row["tick"], row["TextLog:text"][0]) for row in rows(path, "/rules/decisions"))
    assert [(tick, text.split("  ")[-1]) for tick, text in said] == [
        (0, "lost (rule 4) fired; ?child=Human/ben"),
        (2, "lost (rule 4) fired; ?child=Human/ben; scriptinfo.changed: false -> true"),
        (4, "lost (rule 4) fired; ?child=Human/ada"),
        (5, "lost (rule 4) stopped firing"),
    ]


def _message(rule: str, action: str, mutex: str = "M") -> RuleMessage:
    """An alfa/omega message by its letters, as a script writes them."""
    fields = {"rulecode": 1, "id": rule, "intopic": "", "outtopic": ""}
    return msgspec.convert(fields | {"action": ord(action), "mutexcmd": ord(mutex)}, RuleMessage)


def test_alfa_omega_messages_read_as_words_in_order_without_letters() -> None:
    """Thesis 4.3's letters, A/R/D/B/C and L/M/U, in words; a run of one action said once."""
    applied = (
        _message("kick_starter", "R", "L"),
        _message("avoid", "A"),
        _message("greet", "A"),
        _message("nap", "D"),
        _message("nap", "B"),
        _message("kick_starter", "C", "U"),
    )
    assert chain_words(applied) == (
        "map locked · removed kick_starter · added avoid, greet · held for later nap"
        " · brought back nap · recovered kick_starter · map unlocked"
    )


@pytest.mark.parametrize(
    ("path", "value", "said"),
    [
        (
            "scriptinfo.block.led",
            '[{"r":1.0,"g":0.0,"b":0.0,"turnas":1,"wait_t":0,"duration":400},{"r":0.0,"g":0.0,"b":1.0,"tu…',
            "red → …",
        ),
        (
            "scriptinfo.block.move",
            '[{"v_x":0.0,"v_y":0.0,"v_theta":0.6,"wait_t":0,"duration":400}]',
            "turn 0.60 rad/s for 0.4 s",
        ),
        (
            "scriptinfo.block.audioout",
            '[{"track_path":"a/purr.wav","wait_t":0,"duration":1}]',
            "purr.wav",
        ),
        ("scriptinfo.block.move", "[]", "none"),
        ("variables.@rewarded_C", '"30000"', '"30000"'),
        ("humans[0].attributes.note", '"' + "x" * 60 + '"', '"' + "x" * 38 + "…"),
    ],
)
def test_a_rules_change_reads_compactly(path: str, value: str, said: str) -> None:
    """The JSON of a block's channel ran past the pane's edge: it is said in words."""
    assert value_words(path, value) == said


def test_the_sound_pane_names_tracks_as_the_block_line_does(tmp_path: Path) -> None:
    """A track given as a path is named by its file, in the Sound pane as on the block's
    line (the pane once said ``sound sounds/cheer.wav`` beside a line's ``cheer.wav``)."""
    path = tmp_path / "sound.rrd"
    tracks = ["", "sounds/cheer.wav", "sounds/cheer.wav", "bell", ""]
    with RerunSink(path, recording_id="sound", scene=SCENE, world_every_n_ticks=1) as sink:
        for tick, track in enumerate(tracks):
            state = msgspec.structs.replace(world_state(tick), audio=track)
            sink.record(Topic.WORLD_STATE, tick * 20_000_000, state)
    said = [row["TextLog:text"][0] for row in rows(path, "/robot/audio")]
    expected = ["sound off", "sound cheer.wav", "sound bell", "sound off"]
    assert [text.split("  ")[-1] for text in said] == expected


def test_the_text_tabs_show_the_lines_up_to_the_time_cursor_newest_last(tmp_path: Path) -> None:
    """Rerun's text log view lists lines after the cursor too (it said 38.76 s at 26.1 s):
    each tab is a document of its last lines, logged when they change."""
    path = tmp_path / "tabs.rrd"
    with RerunSink(path, recording_id="tabs", scene=SCENE, world_every_n_ticks=1) as sink:
        for tick in range(RECENT_LINES + 4):
            state = msgspec.structs.replace(world_state(tick), audio=f"t{tick}.wav")
            if tick == 3:
                state = msgspec.structs.replace(state, contacts=("child1",))
            sink.record(Topic.WORLD_STATE, tick * 20_000_000, state)
    sound = {row["tick"]: row["TextDocument:text"][0] for row in rows(path, "/recent/sound")}
    assert sorted(sound) == list(range(RECENT_LINES + 4))
    assert sound[1].splitlines() == ["   0.00 s  sound t0.wav", "   0.02 s  sound t1.wav"]
    last = sound[RECENT_LINES + 3].splitlines()
    assert len(last) == RECENT_LINES and last[-1].endswith(f"sound t{RECENT_LINES + 3}.wav")
    log = sorted((row["tick"], row["TextDocument:text"][0]) for row in rows(path, "/recent/log"))
    assert log[-1][1].splitlines() == [
        "   0.06 s  WARN  contact: robot touches child1",  # the level, where it is not INFO
        "   0.08 s  contact with child1 ended",
    ]
    tabs = [
        view
        for view in views(default_blueprint(SCENE).root_container)
        if view.name in ("Script", "Sound", "Rules", "Log")
    ]
    assert [(v.class_identifier, v.origin) for v in tabs] == [
        ("TextDocument", f"recent/{pane}") for pane in ("script", "sound", "rules", "log")
    ]


def test_a_tab_keeps_fewer_lines_when_long_ones_wrap(tmp_path: Path) -> None:
    """Long lines wrap: the tab keeps as many of the newest as fill its rows at 1280x800,
    so the newest stays in sight."""
    path = tmp_path / "wrap.rrd"
    with RerunSink(path, recording_id="wrap", scene=SCENE) as sink:
        for tick in range(RECENT_LINES):
            entry = LogEntry(level=Level.INFO, source="producer", message=f"{tick} " + "x" * 150)
            sink.record(
                Topic.LOG, tick * 20_000_000, LogEntries(tick=tick, time_ms=0, entries=(entry,))
            )
    last = max(rows(path, "/recent/log"), key=lambda row: row["tick"])["TextDocument:text"][0]
    assert [line.split()[3] for line in last.splitlines()] == ["6", "7", "8"]  # 3 rows each
