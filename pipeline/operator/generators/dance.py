"""The thesis's test dance (Fig. 5.10): gentle moves on the beat, LEDs and a track in sync."""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from typing import Final

from oimi.pipeline.messages import RuleAction, Script
from oimi.pipeline.operator.generator import (
    BaseGenerator,
    Colour,
    OptionKind,
    OptionSpec,
    OptionValue,
)
from oimi.pipeline.operator.generators.build import (
    ScriptBuilder,
    alfa_messages,
    audio,
    led,
    move,
    omega_messages,
    safety_rules,
)

TEMPI_BPM: Final = {"slow": 60, "medium": 90, "fast": 120}
"""Named tempi, beats per minute."""

SWAY_MPS: Final = 0.2
"""Sideways and forward speed of a figure, m/s (gentle: at most 0.4)."""
SPIN_RADPS: Final = 1.0
"""Angular speed of a spin figure, rad/s (gentle: at most 1.2)."""

# A figure is two beats there and two back, so the robot ends where it began.
_FIGURES: Final[dict[str, tuple[float, float, float]]] = {
    "sway": (0.0, SWAY_MPS, 0.0),
    "rock": (SWAY_MPS, 0.0, 0.0),
    "spin": (0.0, 0.0, SPIN_RADPS),
    "twirl": (0.0, SWAY_MPS / 2, SPIN_RADPS / 2),
}


class DanceGenerator(BaseGenerator):
    """A dance of ``repetitions`` rounds of figures; each beat changes colour."""

    name = "test_dance"
    title = "Test dance"
    description = (
        "The robot dances on the beat of a track: sways, rocks and spins gently, "
        "its lights changing colour on every beat."
    )
    options = (
        OptionSpec(
            name="tempo",
            kind=OptionKind.CHOICE,
            default="medium",
            choices=tuple(TEMPI_BPM),
            min=40,
            max=160,
            help="slow, medium, fast, or beats per minute",
        ),
        OptionSpec(
            name="colours",
            kind=OptionKind.COLOUR,
            default="red,green,blue",
            multiple=True,
            help="the lights' colours, cycled on the beat",
        ),
        OptionSpec(
            name="repetitions",
            kind=OptionKind.NUMBER,
            default="2",
            min=1,
            max=10,
            integer=True,
            help="how many rounds of figures",
        ),
        OptionSpec(
            name="track",
            kind=OptionKind.TEXT,
            default="tracks/test_dance.wav",
            help="the music played during the dance",
        ),
        OptionSpec(
            name="seed",
            kind=OptionKind.NUMBER,
            default="0",
            min=0,
            max=2**31 - 1,
            integer=True,
            help="picks the order of the figures",
        ),
    )

    def build(self, values: Mapping[str, OptionValue]) -> Script:
        tempo = values["tempo"]
        bpm = TEMPI_BPM[tempo] if isinstance(tempo, str) else float(tempo)
        beat_ms = round(60_000 / bpm)
        colours: tuple[Colour, ...] = values["colours"]  # type: ignore[assignment]
        reps = int(values["repetitions"])  # type: ignore[arg-type]
        track = str(values["track"])
        seed = int(values["seed"])  # type: ignore[arg-type]

        b = ScriptBuilder(self.name)
        b.rules(
            alfa=alfa_messages(*safety_rules(RuleAction.A)),
            omega=omega_messages(*safety_rules(RuleAction.R)),
        )

        b.goal("dance_warm_up")
        b.instruction(
            leds=tuple(led(c, duration_ms=beat_ms) for c in colours),
            sounds=(audio(track, duration_ms=beat_ms * len(colours)),),
        )

        b.goal("dance_figures")
        beat = 0
        for rep in range(reps):
            if rep:
                b.action()
            names = sorted(_FIGURES, key=lambda fig, rep=rep: _shuffle_key(seed, rep, fig))
            moves, leds = [], []
            for fig in names:
                vx, vy, vt = _FIGURES[fig]
                for sign in (1.0, -1.0):
                    moves.append(
                        move(
                            v_x_mps=sign * vx,
                            v_y_mps=sign * vy,
                            v_theta_radps=sign * vt,
                            duration_ms=2 * beat_ms,
                        )
                    )
                    for _ in range(2):
                        leds.append(led(colours[beat % len(colours)], duration_ms=beat_ms))
                        beat += 1
            b.instruction(
                moves=tuple(moves),
                leds=tuple(leds),
                sounds=(audio(track, duration_ms=4 * beat_ms * len(names)),),
            )

        b.goal("dance_bow")
        b.instruction(
            moves=(
                move(v_x_mps=SWAY_MPS / 2, duration_ms=beat_ms),
                move(v_x_mps=-SWAY_MPS / 2, duration_ms=beat_ms),
            ),
            leds=(led((1.0, 1.0, 1.0), duration_ms=2 * beat_ms),),
        )
        b.terminus()
        return b.build()


def _shuffle_key(seed: int, rep: int, figure: str) -> bytes:
    """A stable pseudo-random order of the figures for one seed and repetition."""
    return hashlib.sha256(f"{seed}:{rep}:{figure}".encode()).digest()
