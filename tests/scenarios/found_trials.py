"""Sessions the searches found unsafe once (``test_safety_property.py`` runs them as
examples), as that test's keyword arguments, less the ring (``beams``)."""

from __future__ import annotations

SEED_35 = {  # make soak SEED=35
    "pads": [
        (2, 0.0, 0.0, 0.0, ()),
        (2, 0.0, 0.0, 0.0, ()),
        (2, 0.0, 0.0, 0.0, ()),
        (32, 0.0, 0.0, 0.125, ("LB",)),
        (16, -1.0, 1.0, 0.5, ("LB",)),
        (2, -1.0, 1.0, -0.438, ("LB",)),
    ],
    "moves": [],
    "humans": [((7.536, 6.839), [(4.0, 6.25)], 0.438), ((7.536, 6.839), [(4.0, 6.25)], 0.438)],
    "heading": -0.25,
    "all_round": False,
    "tamper": None,
}
MERGE_176 = {  # its neighbour, unsafe on a real ring (the review of b9a6df9, /tmp/review20)
    "pads": [
        (2, 0.0, 0.0, -0.059, ()),
        (2, 0.0, 0.0, 0.054, ()),
        (2, 0.0, 0.0, 0.122, ()),
        (35, 0.0, 0.0, 0.115, ("LB",)),
        (16, -0.924, 0.94, 0.352, ("LB",)),
        (2, -0.98, 0.906, -0.554, ("LB",)),
    ],
    "moves": [],
    "humans": [((7.462, 6.814), [(3.937, 6.252)], 0.489), ((7.529, 6.832), [(3.929, 6.28)], 0.508)],
    "heading": -0.299,
    "all_round": False,
    "tamper": None,
}
