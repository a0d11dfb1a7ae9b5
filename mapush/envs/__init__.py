"""Pushing environments: the mid-level env and its resets, observations and terminations."""
