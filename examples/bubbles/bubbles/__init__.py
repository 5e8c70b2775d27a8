"""Bubbles: an example oimi extension (see docs/extending.md).

The robot blows "bubbles" (light and sound); a child chases them and pops them by
touching the robot. It adds, through one ``register`` function:

- two condition functions (``E: bubble_touch``, ``E: pops_at_least``),
- a rule (``PopReward``, code 1000) that rewards a touch and talks to the generator,
- a script generator (``bubbles``) that adapts to the child's distance,
- a human behaviour (``chase_bubbles``) and an activity folder.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .behaviour import ChaseBubbles
from .functions import bubble_touch, pops_at_least
from .generator import BubblesGenerator
from .rules import PopReward

if TYPE_CHECKING:
    import oimi

NAME = "bubbles"
__version__ = "1.0"


def register(ext: oimi.Extension) -> None:
    """Everything this extension adds to a session."""
    ext.function(bubble_touch)
    ext.function(pops_at_least)
    ext.rule(PopReward)
    ext.generator(BubblesGenerator)
    ext.behaviour("chase_bubbles", ChaseBubbles)
    ext.activities("activities")
