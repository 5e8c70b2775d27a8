"""Rule firing episodes from the recorded decisions: what `oimi run`'s summary counts and
`oimi analyse` tabulates (one definition for both)."""

from __future__ import annotations

from oimi.pipeline.events import RuleDecisions


class RuleEpisodes:
    """A rule's firing episodes: from the first evaluation that fired to the first that did not
    (decisions are recorded when the chain runs; a rule's result holds until the next)."""

    def __init__(self) -> None:
        self.rows: list[tuple[str, int, int, int | None, int]] = []
        """(rule, rulecode, start_ms, end_ms or None while open, evaluations fired)."""
        self.evaluated: dict[str, int] = {}
        self._open: dict[str, int] = {}

    def update(self, message: RuleDecisions) -> None:
        """Fold one tick's decisions in (a rule missing from them left the chain)."""
        seen = set()
        for d in message.decisions:
            seen.add(d.rule)
            self.evaluated[d.rule] = self.evaluated.get(d.rule, 0) + 1
            index = self._open.get(d.rule)
            if d.fired and index is None:
                self._open[d.rule] = len(self.rows)
                self.rows.append((d.rule, d.rulecode, message.time_ms, None, 1))
            elif d.fired and index is not None:
                rule, code, start, end, count = self.rows[index]
                self.rows[index] = (rule, code, start, end, count + 1)
            elif index is not None:
                self._close(d.rule, message.time_ms)
        for rule in [r for r in self._open if r not in seen]:  # removed from the chain
            self._close(rule, message.time_ms)

    def _close(self, rule: str, time_ms: int) -> None:
        index = self._open.pop(rule)
        name, code, start, _, count = self.rows[index]
        self.rows[index] = (name, code, start, time_ms, count)

    def counts(self) -> dict[str, int]:
        """How many episodes each rule had (one still open counts), by rule."""
        counts: dict[str, int] = {}
        for rule, *_ in self.rows:
            counts[rule] = counts.get(rule, 0) + 1
        return counts

    def fired(self) -> dict[str, int]:
        """How many evaluations of each rule held, over all its episodes, by rule."""
        fired: dict[str, int] = {}
        for rule, _, _, _, count in self.rows:
            fired[rule] = fired.get(rule, 0) + count
        return fired
