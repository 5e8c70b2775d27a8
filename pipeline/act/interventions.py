"""The safety supervisor's interventions as episodes, folded from its ``/safety`` events:
the one definition that ``oimi run``'s summary and expectations and ``oimi analyse`` share."""

from __future__ import annotations

import math

import msgspec
from oimi.pipeline.events import MotionSource, SafetyIntervention, SafetyPhase, SafetyZone


class Intervention(msgspec.Struct, kw_only=True):
    """One intervention episode, gathered from its ``/safety`` events (start to end)."""

    started_ms: int
    ended_ms: int | None = None
    """None: still under way when the events stopped."""
    source: MotionSource
    """The source it first limited."""
    sources: list[MotionSource]
    """Every source it limited, in order."""
    zones: list[SafetyZone]
    """Every zone it reached, in order."""
    humans: list[str]
    min_surface_distance_m: float | None
    requested_mps: float
    """The fastest linear speed asked for during the episode."""
    allowed_mps: float
    """The linear speed let through when it started."""
    changes: int = 0


class Interventions:
    """Folds the supervisor's ``/safety`` events into episodes: the one definition that
    ``oimi run``'s summary and expectations and ``oimi analyse`` share."""

    def __init__(self) -> None:
        self.episodes: list[Intervention] = []
        self._open: Intervention | None = None

    def update(self, event: SafetyIntervention) -> None:
        requested = math.hypot(event.requested[0], event.requested[1])
        episode = self._open
        if event.phase is SafetyPhase.START or episode is None:
            episode = self._open = Intervention(
                started_ms=event.time_ms,
                source=event.source,
                sources=[event.source],
                zones=[event.zone],
                humans=[event.human] if event.human else [],
                min_surface_distance_m=event.surface_distance_m,
                requested_mps=requested,
                allowed_mps=math.hypot(event.allowed[0], event.allowed[1]),
            )
            self.episodes.append(episode)
        else:
            episode.changes += event.phase is SafetyPhase.CHANGE
            for seen, new in ((episode.zones, event.zone), (episode.sources, event.source)):
                if new not in seen:
                    seen.append(new)
            if event.human and event.human not in episode.humans:
                episode.humans.append(event.human)
            if event.surface_distance_m is not None:
                low = episode.min_surface_distance_m
                episode.min_surface_distance_m = (
                    event.surface_distance_m if low is None else min(low, event.surface_distance_m)
                )
            episode.requested_mps = max(episode.requested_mps, requested)
        if event.phase is SafetyPhase.END:
            episode.ended_ms = event.time_ms
            self._open = None
