"""Live sessions (``oimi serve``): the runner paced to the wall clock, with the operator's
App Interface (newline-delimited JSON over TCP) and a web console (HTTP + WebSocket)."""
