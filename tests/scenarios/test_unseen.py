"""Which children the safety property skips as seen by no sensor (``unseen.hidden``), with a
camera whose range is shorter than the ring's reach: the ring's echo of a child beyond the
camera's range keeps them checked; only the ring hiding them too skips them."""

from __future__ import annotations

from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.events import BodyState, WorldState

from tests.scenarios.unseen import hidden

ALL_ROUND_1M = SafetyConfig(camera_fov_rad=6.3, camera_range_m=1.0).filled()
"""A camera seeing all round, reporting a centre within 1 m of the robot's."""


def state(*humans: tuple[float, float]) -> WorldState:
    """The robot at the origin facing +x, the humans (h0, h1...) at those points."""
    robot = BodyState(id="robot", kind="robot", x_m=0.0, y_m=0.0)
    people = tuple(
        BodyState(id=f"h{i}", kind="child", x_m=x, y_m=y) for i, (x, y) in enumerate(humans)
    )
    return WorldState(tick=0, time_ms=0, robot=robot, humans=people)


def test_a_child_beyond_the_camera_s_range_whom_the_ring_echoes_is_not_hidden() -> None:
    """h1 stands 1.2 m away, 40 degrees right, beside h0 (0.9 m ahead, in range): the
    12-sonar ring still hears h1 in a beam h0 does not reach, so the property checks h1 (the
    coverage rule's case: their echo may be merged into h0's)."""
    assert hidden(state((0.9, 0.0), (0.919, -0.771)), ALL_ROUND_1M, 12) == set()


def test_a_child_beyond_the_camera_s_range_behind_a_nearer_one_is_hidden() -> None:
    """h1 stands 1.6 m straight behind h0 (0.8 m): h0 is nearest in every beam h1 reaches
    and h1 is beyond the camera's range, so no sensor sees h1 (within range, the camera
    would: not hidden)."""
    assert hidden(state((0.8, 0.0), (1.6, 0.0)), ALL_ROUND_1M, 12) == {"h1"}
    within = SafetyConfig(camera_fov_rad=6.3, camera_range_m=2.0).filled()
    assert hidden(state((0.8, 0.0), (1.6, 0.0)), within, 12) == set()
