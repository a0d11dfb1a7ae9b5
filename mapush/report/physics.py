"""Whether an object needs a team, in words: its floor drag against one robot's push capacity, both from a job's
recorded physics (`mapush.experiments.job_physics.ObjectPhysics`). A team is needed only where the drag exceeds
what one robot pushes; the tables say which is the case beside the single-agent baseline, with both numbers."""

from __future__ import annotations

from mapush.experiments.job_physics import ObjectPhysics


def team_needed(physics: ObjectPhysics) -> tuple[str, dict[str, float]]:
    """One line: the object's drag against one robot's capacity, and whether one robot can move it alone; and
    those numbers (N)."""
    low, high = physics.drag_n()
    capacity = physics.robot_capacity_n
    numbers = {"drag_low_n": low, "drag_high_n": high}
    if capacity is None:
        return f"drag {low:.1f}-{high:.1f} N", numbers
    verdict = (
        "one robot cannot move it alone"
        if low > capacity
        else "one robot can move it alone"
        if high <= capacity
        else "one robot moves it only where the friction is low"
    )
    line = f"drag {low:.1f}-{high:.1f} N against one robot's capacity {capacity:.1f} N: {verdict}"
    return line, {**numbers, "capacity_n": capacity}


def capacity_margin(physics: ObjectPhysics, mass: float, robots: int) -> float | None:
    """The object's drag at `mass` (kg; the middle of its friction range) over `robots` x one robot's capacity;
    None where the capacity is not known (a legged low level)."""
    if not physics.robot_capacity_n:
        return None
    low, high = physics.drag_n(mass)
    return (low + high) / 2 / (robots * physics.robot_capacity_n)


def known_physics(results) -> ObjectPhysics | None:
    """The physics the first of `results` that knows it records (jobs of one object and setup record the same)."""
    return next((p for p in (r.object_physics() for r in results) if p is not None), None)
