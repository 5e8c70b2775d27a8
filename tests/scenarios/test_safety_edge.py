"""With the sonar ring down the robot drives only where the camera looks: a child centred
just outside the camera's view, whom no sensor ever reports, is not driven into (the
review of e563091, M2; ``tests/pipeline/act/test_act_safety_view.py``)."""

from __future__ import annotations

import math

from oimi.pipeline.events import Topic, WorldState

from tests.scenarios.test_safety_property import RADII_M, STOP_DISTANCE_M, Trial, run_session


def test_a_drive_along_the_view_does_not_reach_a_child_centred_just_outside_it() -> None:
    """The child stands 1.13 m away, 2 degrees outside the 2.2 rad view (beyond the slow
    zone); the ring is offline before its first scan, so no sensor ever reports them. The
    pad asks for 1 m/s at them for 4.9 s: the robot drives at the slow speed along the
    view's edge, narrowed for a body at it, and passes them 0.18 m apart (along the
    view's own edge it drove into them, surface to surface -0.005 m)."""
    pad = (245, -0.905, 0.426, 0.0, ("LB",))  # v_x 0.426, v_y 0.905: 65 degrees left
    child = ((6.481, 7.024), [], 0.0)
    offline = (0.0, "sonar", "offline")
    memory = run_session(Trial([pad], [], [child], 0.0, False, faults=[offline])).memory
    reported = {
        change.objectid
        for update in memory.on(Topic.SENSOR_UPDATES)
        for change in update.updates  # type: ignore[attr-defined]
        if change.attributename == "poses"
    }
    assert reported == set()  # nobody: the camera never saw them, the ring never scanned
    states: list[WorldState] = memory.on(Topic.WORLD_STATE)  # type: ignore[assignment]
    assert max(math.hypot(s.robot.vx_mps, s.robot.vy_mps) for s in states) > 0.19  # it drove
    gap = min(
        math.hypot(h.x_m - s.robot.x_m, h.y_m - s.robot.y_m) - RADII_M
        for s in states
        for h in s.humans
    )
    assert gap > STOP_DISTANCE_M  # out of the stop zone
