"""Stand-ins for tests: envs for the pure term functions (only the attributes a term reads, state fields under
`env.state` as the real envs keep them: `PushState`, `LocomotionState`), stage runs with hand-made iteration
times for the cost and archive tests, which bodies touch in a MuJoCo state, and the check every bad-input test makes
of the command line's answer (`assert_bad_input`)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import torch
from omegaconf import OmegaConf

from mapush.config import compose_config
from mapush.envs.locomotion import LocomotionState
from mapush.experiments.results import JobResult
from mapush.logging.mcap_files import CPU_TAG
from mapush.logging.metrics import McapLogWriter
from mapush.sim.push import PushState

STATE_FIELDS = {f.name for f in dataclasses.fields(PushState)} | {f.name for f in dataclasses.fields(LocomotionState)}


def stand_in_env(**attrs) -> SimpleNamespace:
    """An env whose state fields (e.g. `object_xy`, `lin_vel`) are under `.state` and the rest on the env itself."""
    state = {name: attrs.pop(name) for name in list(attrs) if name in STATE_FIELDS}
    return SimpleNamespace(state=SimpleNamespace(**state), **attrs)


def as_results(records: list[dict]) -> list[JobResult]:
    """Hand-made job results: each dict's fields, the rest at their defaults."""
    return [JobResult(**record) for record in records]


def stage_run(
    root: Path, name: str, threads: int, parts: list[dict[int, tuple[float, ...]]], recorded: list[int] | None = None
) -> Path:
    """A run dir with one metrics file per part: {iteration: (collection s, learning s[, CPU s])}; `recorded`: the
    threads each part's iterations record (`Perf/threads`; 0, as files written before that record, or None: none).
    An iteration records CPU seconds (`Perf/cpu_s`) only where given."""
    run = root / name
    run.mkdir(parents=True)
    OmegaConf.save(compose_config([f"sim.nthread={threads}"]), run / "config.yaml")
    for part, part_threads in zip(parts, recorded or [0] * len(parts), strict=True):
        # a second writer opens metrics.1.mcap, as a resume does
        writer = McapLogWriter(str(run), progress=False, threads=part_threads, record_cpu=False)
        for it, (collection, learning, *cpu) in part.items():
            writer.add_scalar("Perf/collection_time", collection, it)
            writer.add_scalar("Perf/learning_time", learning, it)
            for seconds in cpu:
                writer.add_scalar(CPU_TAG, seconds, it)
            writer.add_scalar("Metrics/success_rate", 0.5, it)
            writer.end_iteration(it)
        writer.stop()
    (run / "policy.pt").write_bytes(b"")
    return run


def touching_pairs(model, data) -> set[tuple[str, str]]:
    """The pairs of bodies that touch in `data`, as MuJoCo's collision detection lists them (after `mj_forward`),
    each body named by its robot prefix (`robot0`, ...) or its own name (`object`, `world`), sorted."""
    owner = [model.body(model.geom_bodyid[g]).name.split("/")[0] for g in range(model.ngeom)]
    return {tuple(sorted((owner[c.geom1], owner[c.geom2]))) for c in data.contact[: data.ncon]}


def assert_bad_input(proc, *fragments: str) -> str:
    """Exit 2 with exactly one `mapush: error:` line on stderr that contains every fragment; returns the line."""
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("mapush: error: ")
    for fragment in fragments:
        assert fragment in lines[0]
    return lines[0]


def face_two_robots(env) -> None:
    """Env 0 of a one-env, two-robot mid level: the robots 2 m apart facing each other, the object 8 m away."""
    layout = {
        "object_xy": torch.tensor([[8.0, 8.0]]),
        "object_yaw": torch.zeros(1),
        "robot_xy": torch.tensor([[[-1.0, 0.0], [1.0, 0.0]]]),
        "robot_yaw": torch.tensor([[0.0, math.pi]]),
        "subgoal_xy": torch.tensor([[8.0, 9.0]]),
        "friction": torch.tensor([0.3]),
    }
    env.sim.reset(np.array([0]), layout)
    env._read_state()
