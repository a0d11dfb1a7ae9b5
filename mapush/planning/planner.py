"""Planning the object's path with OMPL (ompl 2.x nanobind bindings), for evaluation of the whole hierarchy.

The object is planned for as a point in R^2: obstacles are inflated by the object's radius (its circumscribed
disc, so any heading is safe) plus a margin, and the room's walls by the same amount. RRTConnect by default; any
geometric OMPL planner can be named in `planner.name`. The simplified path is checked against the un-inflated
geometry (obstacles grown by the object radius only) at 2 cm steps and resampled to the waypoints the high level
consumes. An unreachable goal gives `PlanResult(solved=False)`, which evaluation counts as a planner failure.

A plan ends on work done, never on seconds, so that a seeded evaluation plans the same paths on a fast machine and
a slow or loaded one: the planner stops at its first solution (RRTConnect) or after `max_checks` state validity
checks, and simplification runs to its fixed point. `time_limit_s` stays as a safety net only; a plan it stops
depends on the machine, so it is counted (`ObjectPlanner.wall_clock_stops`) and reported by evaluation.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import torch
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from mapush.errors import BadInput
from mapush.planning.geometry import point_distance
from mapush.planning.paths import resample

CHECK_STEP = 0.02
"""m between the points at which a finished path is validated."""


def planner_names() -> list[str]:
    """Geometric OMPL planners that can be built from SpaceInformation alone."""
    names = []
    for name in dir(og):
        cls = getattr(og, name)
        if isinstance(cls, type) and issubclass(cls, ob.Planner) and name[0].isupper() and name != "Planner":
            names.append(name)
    return sorted(names)


@dataclass
class PlanResult:
    """One planning query's outcome; `path` is None when no exact solution was found."""

    path: np.ndarray | None  # (waypoints, 2)
    solved: bool
    valid: bool
    planning_time_s: float
    length_m: float


class ObjectPlanner:
    """Plans object paths among rectangular obstacles in a square room (one instance per process; reusable).

    Args:
        planner_cfg: `name`, `max_checks` (the work budget), `time_limit_s` (a wall-clock safety net), `range_m`,
            `margin_m`, `resolution_m`, `simplify`.
        arena_size: room side, m (the room is centred on the origin).
        object_radius: circumscribed radius of the object's footprint, m.
        seed: seeds OMPL's process-wide RNG seed generator, so that a sequence of plans repeats (the planner's
            samplers draw their seeds from it when first solving). None leaves OMPL's random seed.
    """

    def __init__(self, planner_cfg: dict, arena_size: float, object_radius: float, seed: int | None = None):
        if seed is not None:
            # OMPL logs an error when the generator has already handed out seeds (an earlier planner in this
            # process); reseeding still makes the new planner's sampling repeat, so silence that message
            ou.setLogLevel(ou.LogLevel.LOG_NONE)
            ou.RNG.setSeed(seed % (2**31 - 1) + 1)  # OMPL seeds are positive
        ou.setLogLevel(ou.LogLevel.LOG_ERROR)  # OMPL prints Info/Debug to stdout otherwise
        self.cfg = planner_cfg
        self.radius = object_radius
        self.inflate = object_radius + planner_cfg["margin_m"]
        half = arena_size / 2
        self.space = ob.RealVectorStateSpace(2)
        bounds = ob.RealVectorBounds(2)
        bounds.setLow(-half + self.inflate)
        bounds.setHigh(half - self.inflate)
        self.space.setBounds(bounds)
        self.half_free = half - object_radius  # validation bound (no margin)
        self.setup = og.SimpleSetup(self.space)
        self.setup.setStateValidityChecker(self._is_valid)
        si = self.setup.getSpaceInformation()
        si.setStateValidityCheckingResolution(planner_cfg["resolution_m"] / self.space.getMaximumExtent())
        name = planner_cfg["name"]
        if not hasattr(og, name) or name not in planner_names():
            raise BadInput(f"unknown planner {name!r}; valid: {', '.join(planner_names())}")
        self.planner = getattr(og, name)(si)
        if hasattr(self.planner, "setRange"):
            self.planner.setRange(planner_cfg["range_m"])
        self.setup.setPlanner(self.planner)
        self._rects: list[tuple[float, float, float, float, float, float]] = []
        self.checks = 0  # state validity checks in the current plan: the planner's work
        self.wall_clock_stops = 0  # plans the safety net stopped before the work budget ran out

    def _is_valid(self, state) -> bool:
        """Outside every inflated obstacle (pure Python: OMPL calls this thousands of times per plan)."""
        self.checks += 1
        x, y = state[0], state[1]
        limit = self.inflate
        for cx, cy, c, s, hx, hy in self._rects:
            dx, dy = x - cx, y - cy
            lx, ly = abs(c * dx + s * dy) - hx, abs(-s * dx + c * dy) - hy
            if lx < limit and ly < limit and math.hypot(max(lx, 0.0), max(ly, 0.0)) < limit:
                return False
        return True

    def plan(self, start: np.ndarray, goal: np.ndarray, obstacles: np.ndarray, waypoints: int) -> PlanResult:
        """Plan from `start` to `goal` (2,) among `obstacles` (K, 5) and resample to `waypoints` points."""
        self._rects = [
            (float(o[0]), float(o[1]), math.cos(o[2]), math.sin(o[2]), float(o[3]) / 2, float(o[4]) / 2)
            for o in obstacles
        ]
        began = time.perf_counter()
        self.setup.clear()
        s, g = self.space.allocState(), self.space.allocState()
        s[0], s[1] = float(start[0]), float(start[1])
        g[0], g[1] = float(goal[0]), float(goal[1])
        if not (self._is_valid(s) and self._is_valid(g)):
            return PlanResult(None, False, False, time.perf_counter() - began, 0.0)
        self.setup.setStartAndGoalStates(s, g, 0.05)
        self.checks = 0
        budget = int(self.cfg["max_checks"])
        work_done = ob.PlannerTerminationCondition(lambda: self.checks >= budget)
        safety_net = ob.timedPlannerTerminationCondition(float(self.cfg["time_limit_s"]))
        self.setup.solve(ob.plannerOrTerminationCondition(work_done, safety_net))
        if self.checks < budget and time.perf_counter() - began >= float(self.cfg["time_limit_s"]):
            self.wall_clock_stops += 1
        if not self.setup.haveExactSolutionPath():  # an approximate solution is a failure
            return PlanResult(None, False, False, time.perf_counter() - began, 0.0)
        if self.cfg["simplify"]:
            self.setup.simplifySolution()  # no duration: simplify until nothing changes (work, not time)
        solution = self.setup.getSolutionPath()
        raw = np.array([[solution.getState(i)[0], solution.getState(i)[1]] for i in range(solution.getStateCount())])
        elapsed = time.perf_counter() - began
        path = resample(torch.from_numpy(raw).float(), waypoints)
        valid = self.path_is_valid(raw, obstacles)
        length_m = float(np.linalg.norm(np.diff(raw, axis=0), axis=1).sum())
        return PlanResult(path.numpy(), True, valid, elapsed, length_m)

    def path_is_valid(self, path: np.ndarray, obstacles: np.ndarray) -> bool:
        """Every point of the polyline, at `CHECK_STEP`, keeps the object's disc off the true obstacles and walls."""
        seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
        pts = [path[:1]]
        for a, b, d in zip(path[:-1], path[1:], seg, strict=True):
            n = max(math.ceil(d / CHECK_STEP), 1)
            pts.append(a + (b - a) * (np.arange(1, n + 1) / n)[:, None])
        dense = torch.from_numpy(np.concatenate(pts)).float()
        inside = bool((dense.abs() <= self.half_free + 1e-6).all())
        if len(obstacles) == 0:
            return inside
        clear = point_distance(dense, torch.as_tensor(obstacles, dtype=torch.float32)).amin().item()
        return inside and clear >= self.radius - 1e-4

    def close(self) -> None:
        """Drop the OMPL objects (nanobind reports objects alive at exit as leaks)."""
        self.setup = self.planner = self.space = None
