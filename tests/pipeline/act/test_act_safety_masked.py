"""The safety supervisor and a child the ring hears only by a beam that clips their edge:
the beam holding their nearest point hears a nearer body (a pole), and the child stands
behind the robot, outside the camera's view. That echo's arc does not hold the child's
centre (it lies beyond the beam's edge, up to ``human_radius_m * sqrt(2)`` from the arc's
end), yet the echoes bound the child: each beam's range is no farther than any point of
any body in it, so every point of the child lies in a beam whose echo's disc reaches
nearer along its ray (``pipeline/act/echoes.py``). The ring is the simulator's own
(``beam_echoes``, 12 sonars of nearest surfaces, scanning at 5 Hz)."""

from __future__ import annotations

import msgspec
import pytest
from test_act_safety_held import RING, approach, behind


@pytest.mark.parametrize(
    ("surface", "child", "pole"),
    [
        (True, (186.0, 1.6), (180.0, 1.3)),
        (True, (186.0, 1.2), (180.0, 0.9)),
        (True, (194.0, 1.6), (190.0, 1.3)),
        (False, (194.0, 1.6), (190.0, 1.3)),
    ],
)
def test_a_child_masked_in_their_nearest_beam_is_bounded_by_the_beams_that_clip_them(
    surface: bool, child: tuple[float, float], pole: tuple[float, float]
) -> None:
    """A child (bearing in degrees, centre's distance in m) behind a pole 5 cm thick
    nearer in the beam holding the child's nearest point; the robot asks to drive straight
    at the child for 5 s. On most scans the ring hears the child only where a neighbouring
    beam's edge enters their disc (``echo-0.s<K>``, never ``echo-0``), yet the robot stays
    out of the child's stop zone and closes on them no faster than ``slow_speed_mps`` within
    their slow zone, on a ring of surfaces or (``sonar_reports_surface`` false) one taken
    for centres (the ring hears the pole on 24 or 25 of the 25 scans; the robot stops 0.42
    to 0.67 m from the child). A model that narrowed an echo's arc to its axis's point
    closed on them at 0.2016 and 0.2004 m/s in the first two cases; one that placed an
    echo's centre two radii beyond its range (its disc no longer reaching back to the range)
    at 0.31 to 0.35 m/s in the first three."""
    config = msgspec.structs.replace(RING, sonar_reports_surface=surface)
    ticks, nearest, scans = approach(
        {"0": behind(*child)}, "0", range(0), config=config, posts=(behind(*pole),), seconds=5.0
    )
    clipped = [ids for ids in scans if ids and "echo-0" not in ids]
    assert len(clipped) >= 15  # of 25 scans: the child's nearest beam hears the pole
    assert nearest >= config.stop_distance_m
    slow = [closing for _, _, closing, gap in ticks if gap < config.slow_distance_m]
    assert max(slow, default=0.0) <= config.slow_speed_mps + 1e-9
