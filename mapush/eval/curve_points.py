"""Reading a learning curve (points of env-steps and evaluated success, `curves.learning_curve`): when it first
reaches a rate, and what its last stretch added. Plain arithmetic, so a table reads curves without the
simulator."""

from __future__ import annotations

RATE_DECIMALS = 6
"""Decimals a success rate keeps when curves are compared: rates are float32 means (0.6 may be 0.59999996), and no
evaluation has a million episodes."""


def clean_rate(rate: float) -> float:
    """`rate` without its float32 noise (and never -0.0), so that a rule's bound is met or not as printed."""
    return round(float(rate), RATE_DECIMALS) + 0.0


def first_reaching(points: list[dict], threshold: float) -> dict | None:
    """The first point whose success rate is at least `threshold` (its keys but the rates), or None."""
    for point in points:
        if point["success_rate"] >= threshold - 1e-6:  # rates are float32 means: 0.6 may be 0.59999996
            return {k: v for k, v in point.items() if not k.startswith(("success", "completion"))}
    return None


def tail_start(points: list[dict], tail: float) -> dict | None:
    """The point where the last `tail` fraction of the env-steps starts: the earlier point nearest to (1 - tail) of
    the final env-steps (the earlier of two as near); None with one point."""
    if len(points) < 2:
        return None
    cut = (1 - tail) * points[-1]["env_steps"]
    return min(points[:-1], key=lambda p: (abs(p["env_steps"] - cut), p["env_steps"]))


def tail_gain(points: list[dict], tail: float) -> float | None:
    """Success gained over the last `tail` fraction of the env-steps: the last point's rate minus that of
    `tail_start`; None with one point."""
    start = tail_start(points, tail)
    return None if start is None else clean_rate(points[-1]["success_rate"] - start["success_rate"])


def steps_to_reach(points: list[dict], target: float, tail: float) -> float | None:
    """The env-steps at which the curve would reach success `target`, going on as its last `tail` went (a straight
    line through `tail_start` and the last point): the last point's env-steps if it is there already, None if the
    curve does not rise over its tail (or has one point)."""
    start, last = tail_start(points, tail), points[-1]
    if last["success_rate"] >= target:
        return float(last["env_steps"])
    if start is None or last["success_rate"] <= start["success_rate"]:
        return None
    slope = (last["success_rate"] - start["success_rate"]) / (last["env_steps"] - start["env_steps"])
    return last["env_steps"] + (target - last["success_rate"]) / slope
