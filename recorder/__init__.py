"""Sinks and readers: MCAP (Foxglove-readable) and Rerun recordings (docs/recording.md)."""
