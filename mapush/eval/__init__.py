"""Deterministic evaluation of trained policies: success rate and completion time over seeds."""
