"""The robot's physical ceiling: figures no scenario file or ``--param`` can exceed.

The thesis robot (section 5.2, after Teo/Oimi, section 2.3) is an omni-directional
disc on Swedish wheels, "a 60 cm tall egg" of about a child's size. The thesis
gives no speed, acceleration or mass: the ceilings below are oimi's decision,
twice the scenario defaults (a walking child's pace at most), and documented in
``docs/scenario-files.md``. The loader refuses a robot section above them.
"""

from __future__ import annotations

from typing import Final

import msgspec


class RobotProfile(msgspec.Struct, frozen=True, kw_only=True):
    """The largest value each robot field may take; field names match ``RobotSpec``."""

    name: str
    radius_m: float
    mass_kg: float
    max_speed_mps: float
    max_angular_speed_radps: float
    max_accel_mps2: float
    max_angular_accel_radps2: float

    def ceilings(self) -> dict[str, float]:
        """Field name -> ceiling, in field order."""
        return {name: getattr(self, name) for name in self.__struct_fields__ if name != "name"}


THESIS_ROBOT: Final = RobotProfile(
    name="thesis robot",
    radius_m=0.5,
    mass_kg=50.0,
    max_speed_mps=1.0,
    max_angular_speed_radps=3.0,
    max_accel_mps2=2.0,
    max_angular_accel_radps2=6.0,
)
"""The omni-directional robot of the thesis (defaults: 0.3 m, 20 kg, 0.5 m/s, 1.5 rad/s,
1 m/s², 3 rad/s²)."""
