"""Whether the tracker falls where its Go1 does, in every calibration test with a fall outcome.

Four tests load a robot until it may fall (`capacity.py`, `squeeze.py`): walking into a load of growing drag
(`push`), walking under a load held back on its trunk (`held`), pinned by teammates in six layouts (`squeezes`),
and shoved back through the cuboid by a pair at growing speeds (`shoves`). The Go1's falls are counted; the
tracker's are its fall model's expectation, 1 - exp(-H) per trial with H its fall hazard integrated over the test
(the tracker's motion does not depend on whether it fell, so the expectation carries no draw's noise).

Grades with few trials are pooled with their neighbours until a group holds `MIN_TRIALS` (a share of 24 trials
has a standard error of up to 10 points); in every group the tracker's fall share must lie within `TOLERANCE` of
the Go1's. `mapush calibrate` writes no tracker that fails, and `tests/.../test_consistency.py` checks the committed
calibration with `compare`.
"""

from __future__ import annotations

import numpy as np

from mapush.calibration import capacity as cap
from mapush.calibration import squeeze

TOLERANCE = 0.10
"""The largest gap between the tracker's and the Go1's fall share in any group of a test."""
MIN_TRIALS = 24
"""Trials a group of grades holds at least (the graded shove's and each squeeze's size at the default repeats)."""
TESTS = ("push", "held", "squeezes", "shoves")
"""The calibration's tests with a fall outcome, as `calibration.json`'s `consistency` names them."""


class HazardProbe:
    """Hooks for `lags.run_steps` (`during`, `after`) that record a tracker's fall state over a test's hold: the
    contact `load` (E, T, A) in N and the hazard rate from its other channels `other_rate` (E, T, A) in 1/s, and the
    hazard integrated over the hold `hazard` (E, A)."""

    def __init__(self):
        self.loads, self.others, self.helds, self.start, self.end, self.dt = [], [], [], None, None, None

    def during(self, sim) -> None:
        if self.start is None:
            self.start, self.dt = self._hazard(sim), sim.dt
        self._before = self._hazard(sim)

    def after(self, sim) -> None:
        robots = sim.lowlevel
        if robots.fall is None:  # a tracker that cannot fall: no load read, no hazard
            zeros = self._hazard(sim)
            self.loads.append(zeros)
            self.others.append(zeros)
            self.end = zeros
            return
        self.loads.append(robots.load.copy())
        if getattr(robots, "held_channel", False):
            self.helds.append(robots.held.copy())
        step_rate = (robots.hazard - self._before) / sim.dt
        self.others.append(np.maximum(step_rate - robots.load_rate(robots.load), 0.0))
        self.end = robots.hazard.copy()

    @staticmethod
    def _hazard(sim) -> np.ndarray:
        """The robots' accumulated hazard (E, A); zeros for a tracker without a fall model."""
        robots = sim.lowlevel
        if robots.fall is not None:
            return robots.hazard.copy()
        return np.zeros((sim.batch.nsim, len(robots.qpos_idx)))

    @property
    def hazard(self) -> np.ndarray:
        return self.end - self.start

    @property
    def load(self) -> np.ndarray:
        return np.stack(self.loads, 1)

    @property
    def other_rate(self) -> np.ndarray:
        return np.stack(self.others, 1)

    @property
    def held(self) -> np.ndarray:
        """(E, T, A) N: the low-passed load applied to each body (a tracker with a held-load channel)."""
        return np.stack(self.helds, 1)


HELD_MIDPOINTS = np.arange(0.0, 126.25, 0.25)
"""N; the held-load curve's midpoints `fit_held_curve` tries: the calibration's whole load grid."""
HELD_WIDTHS = np.geomspace(0.05, 20.0, 80)
"""N; its widths: from a step to a slope across a fifth of the grid."""


def fit_held_curve(probe: HazardProbe, fell: np.ndarray, window_s: float) -> dict[str, float] | None:
    """The held-load curve (`held_n`, `held_width_n`) of greatest likelihood for the Go1's falls `fell` (E,) under a
    held load, when the tracker's chance to fall in each trial is 1 - exp(-H), H its held-load hazard integrated over
    the loads it recorded (`probe.held`, the tracker in the same starts): fitted on the tracker's own load, as it
    will read it, so that its falls match the Go1's where it was measured; None when the Go1 never fell."""
    fell = np.asarray(fell, dtype=bool)
    if not fell.any():
        return None
    held = probe.held[..., 0]  # (E, T): robot 0, the only one
    best = (-np.inf, None)
    for width in HELD_WIDTHS:
        z = (held[None] - HELD_MIDPOINTS[:, None, None]) / width  # (M, E, T)
        p = np.minimum(1.0 / (1.0 + np.exp(-np.clip(z, -60.0, 60.0))), 1.0 - 1e-9)
        hazard = (-np.log1p(-p)).sum(-1) * probe.dt / window_s  # (M, E)
        share = np.clip(1.0 - np.exp(-hazard), 1e-9, 1 - 1e-9)
        ll = np.where(fell[None], np.log(share), np.log1p(-share)).sum(-1)
        if ll.max() > best[0]:
            best = (float(ll.max()), {"held_n": float(HELD_MIDPOINTS[int(ll.argmax())]), "held_width_n": float(width)})
    return best[1]


def expected_falls(hazard: np.ndarray) -> dict[str, np.ndarray]:
    """Per trial, from the integrated hazards (E, A): the probability that robot 0 fell (`first`) and that any robot
    did (`any`)."""
    return {"first": 1.0 - np.exp(-hazard[:, 0]), "any": 1.0 - np.exp(-hazard.sum(-1))}


def contact_hazard(load: np.ndarray, other_rate: np.ndarray, dt: float, load_n, width_n: float, window_s: float):
    """The hazard (M, E, A) a contact fall curve of midpoints `load_n` (M,) and width `width_n` would integrate over
    the recorded contact loads (E, T, A), plus the other channels' recorded rates."""
    midpoints = np.asarray(load_n, dtype=np.float64).reshape(-1, 1, 1, 1)
    p = 1.0 / (1.0 + np.exp(-np.clip((load[None] - midpoints) / width_n, -60.0, 60.0)))
    rate = -np.log1p(-np.minimum(p, 1.0 - 1e-9)) / window_s
    return (rate.sum(2) + other_rate.sum(1)[None]) * dt


def groups(grades, trials, go1_falls, tracker_falls, min_trials: int = MIN_TRIALS) -> list[dict]:
    """Adjacent grades (in the order given) pooled until each group holds `min_trials` trials (a short remainder
    joins the last group): per group its grades, trials and the Go1's and the tracker's fall shares."""
    out, current = [], None
    for grade, n, go1, tracker in zip(grades, trials, go1_falls, tracker_falls, strict=True):
        if current is None or current["trials"] >= min_trials:
            current = {"grades": [], "trials": 0, "go1": 0.0, "tracker": 0.0}
            out.append(current)
        current["grades"].append(grade)
        current["trials"] += int(n)
        current["go1"] += float(go1)
        current["tracker"] += float(tracker)
    if len(out) > 1 and out[-1]["trials"] < min_trials:
        last = out.pop()
        for key in ("grades", "trials", "go1", "tracker"):
            out[-1][key] += last[key]
    for group in out:
        group["go1"] /= group["trials"]
        group["tracker"] /= group["trials"]
        group["ok"] = abs(group["tracker"] - group["go1"]) <= TOLERANCE + 1e-12
    return out


def per_grade(grade: np.ndarray, go1_fell: np.ndarray, tracker_p: np.ndarray) -> tuple[list, list, list, list]:
    """Per-trial records (E,) summed per grade, in grade order: grades, trials, Go1 falls, tracker's expected falls."""
    values = np.unique(grade)
    trials = [int((grade == g).sum()) for g in values]
    go1 = [float(np.asarray(go1_fell, dtype=float)[grade == g].sum()) for g in values]
    tracker = [float(np.asarray(tracker_p, dtype=float)[grade == g].sum()) for g in values]
    return values.tolist(), trials, go1, tracker


def compare(summary: dict) -> dict:
    """The consistency of a calibration's record (`calibration.json`'s `push`, `falls`, `squeezes`, `shoves`, each
    with the tracker's expected falls): {test: groups}, `failed` (the tests with a group out of `TOLERANCE`) and
    `passed`. A test the record lacks the tracker's side of fails."""
    tests: dict[str, list[dict]] = {}
    push, held = summary.get("push", {}), summary.get("falls", {})
    for name, record, key in (("push", push, "drag_n"), ("held", held, "load_n")):
        if "tracker_fall_p" in record:
            tests[name] = groups(*per_grade(np.array(record[key]), np.array(record["fell"]), record["tracker_fall_p"]))
    squeezes = summary.get("squeezes") or {}
    if "tracker_fell" in squeezes:
        n = squeezes["envs"]
        tests["squeezes"] = [
            group
            for layout, counts in zip(
                squeezes["layout"], zip(*(squeezes[k] for k in SQUEEZE_KEYS), strict=True), strict=True
            )
            for who, (go1, tracker) in (("robot 0", counts[:2]), ("any robot", counts[2:]))
            for group in groups([f"{layout}, {who}"], [n], [go1 * n], [tracker * n], min_trials=1)
        ]
    shoves = summary.get("shoves") or {}
    if "tracker_fall_p" in shoves:
        n = shoves["envs"]
        tests["shoves"] = groups(
            shoves["pair_speed"],
            [n] * len(shoves["fell"]),
            np.array(shoves["fell"]) * n,
            np.array(shoves["tracker_fall_p"]) * n,
        )
    failed = [name for name in TESTS if name not in tests or not all(g["ok"] for g in tests[name])]
    return {"tolerance": TOLERANCE, "min_trials": MIN_TRIALS, "tests": tests, "failed": failed, "passed": not failed}


SQUEEZE_KEYS = ("first_fell", "tracker_first_fell", "fell", "tracker_fell")
"""`squeezes`' per-layout shares: robot 0's falls (the Go1's, the tracker's expected), then any robot's."""


def describe(result: dict) -> list[str]:
    """One line per failing group: which test, which grades, both shares."""
    lines = []
    for name in result["failed"]:
        if name not in result["tests"]:
            lines.append(f"{name}: no tracker measurement")
            continue
        for g in result["tests"][name]:
            if not g["ok"]:
                grades = f"{g['grades'][0]}" + (f" to {g['grades'][-1]}" if len(g["grades"]) > 1 else "")
                lines.append(
                    f"{name} at {grades}: the tracker falls in {g['tracker']:.0%}, its Go1 in {g['go1']:.0%} of "
                    f"{g['trials']} trials (more than {TOLERANCE:.0%} apart)"
                )
    return lines


MAX_CONTACT_LOAD_N = 400.0
"""N; the highest contact fall midpoint `fit_contact_midpoint` tries: beyond what four trackers' caps put on one."""


def measure_tracker(tracker: list[str], repeats: int, seed: int, envs: int) -> dict:
    """The tracker of `tracker` (overrides, with a `fall` model) in the four tests, as `mapush calibrate` runs them
    on the Go1: per test its `HazardProbe`s, and the push sweep's object speeds."""
    probes = {name: HazardProbe() for name in ("push", "held", "shoves")}
    push = cap.push_sweep(tracker, repeats, seed, probe=probes["push"])
    cap.fall_sweep(tracker, repeats, seed, probe=probes["held"])
    layouts = [HazardProbe() for _ in squeeze.LAYOUTS]
    squeeze.squeeze_sweep(tracker, envs, seed, probes=layouts)
    squeeze.shove_sweep(tracker, envs, seed, probe=probes["shoves"])
    return {**probes, "squeezes": layouts, "push_speed": push["speed"]}


def tracker_record(measured: dict, speeds: int) -> dict:
    """The tracker's expected falls of `measure_tracker`'s probes, as `calibration.json` keeps them beside the
    Go1's: per-trial `push` and `held` (E,), per-layout `squeezes` robot 0 and any robot (L,), and per pair speed
    (`speeds` of them) `shoves`."""
    first = [expected_falls(p.hazard) for p in measured["squeezes"]]
    shoves = expected_falls(measured["shoves"].hazard)["first"].reshape(speeds, -1).mean(1).tolist()
    return {
        "push": expected_falls(measured["push"].hazard)["first"].tolist(),
        "held": expected_falls(measured["held"].hazard)["first"].tolist(),
        "squeezes_first": [float(f["first"].mean()) for f in first],
        "squeezes_any": [float(f["any"].mean()) for f in first],
        "shoves": shoves,
    }


def fit_contact_midpoint(measured: dict, go1: dict, model: dict, resolution: float = 0.5) -> float | None:
    """The lowest contact fall midpoint (N, to `resolution`) from the held-load curve's up to `MAX_CONTACT_LOAD_N`
    at which the tracker, as `measure_tracker` recorded its contact loads, falls in no group of the push sweep, the
    squeezes or the graded shove more than `TOLERANCE` more often than the Go1 (`go1`: `push_drag`, `push_fell`
    per trial, `squeeze_first`, `squeeze_any` per layout, `shove_fell` per speed, `envs`); None when none does.
    Its falls only shrink as the midpoint rises, so a bisection finds it. The held-load test has no contact load."""
    width, window = float(model["width_n"]), float(model["window_s"])

    def too_many(midpoint: float) -> bool:
        def share(probe: HazardProbe) -> dict[str, np.ndarray]:
            hazard = contact_hazard(probe.load, probe.other_rate, probe.dt, [midpoint], width, window)[0]
            return expected_falls(hazard)

        push = share(measured["push"])["first"]
        grouped = groups(*per_grade(np.asarray(go1["push_drag"]), np.asarray(go1["push_fell"]), push))
        excess = [g["tracker"] - g["go1"] for g in grouped]
        for k, probe in enumerate(measured["squeezes"]):
            falls = share(probe)
            excess += [falls["first"].mean() - go1["squeeze_first"][k], falls["any"].mean() - go1["squeeze_any"][k]]
        shoves = share(measured["shoves"])["first"].reshape(len(go1["shove_fell"]), -1).mean(1)
        excess += list(shoves - np.asarray(go1["shove_fell"]))
        return max(excess) > TOLERANCE

    low, high = float(model["held_n"]), MAX_CONTACT_LOAD_N
    if not too_many(low):
        return low
    if too_many(high):
        return None
    while high - low > resolution:
        mid = (low + high) / 2
        low, high = (mid, high) if too_many(mid) else (low, mid)
    return high
