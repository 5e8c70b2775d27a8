"""Fuzz tests: oimi fed damaged, truncated and generated input, as a careless user and a
damaged disk would. The property everywhere: exit 0, 1 or 2 with a located message; never a
traceback, a hang or a signal. ``OIMI_FUZZ_EXAMPLES`` scales the example counts
(``make fuzz`` runs them longer)."""
