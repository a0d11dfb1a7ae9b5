"""The simulation core: E copies of one MuJoCo model stepped together by `mujoco.batch.Batch` on every core.

Every level simulates through a `BatchSim`: the pushing levels through `PushSim` (`mapush.sim.push`), the
locomotion level through a plain one over its Go1 model. It owns the MuJoCo side only: the batch, its live state
arrays, partial resets and stepping with failure ids. The env logic lives in `mapush.envs`.
"""

from __future__ import annotations

import os

import mujoco
import numpy as np
from mujoco import batch as mjb

from mapush.errors import BadInput

BAD_STATE_WARNINGS = [
    int(mujoco.mjtWarning.mjWARN_BADQPOS),
    int(mujoco.mjtWarning.mjWARN_BADQVEL),
    int(mujoco.mjtWarning.mjWARN_BADQACC),
]
"""MuJoCo's warnings for a NaN, infinite or huge state: it then resets that sim to the model's defaults and steps
on, so the state read afterwards is finite again and only these counters tell that the sim diverged."""


def _check_memory(model: mujoco.MjModel, num_envs: int) -> None:
    """BadInput before allocating when the simulations' state buffers alone (`model.nbuffer` bytes each, written at
    once; the arena, `model.narena`, is reserved and touched as contacts need it) exceed the memory available."""
    available = _available_bytes()
    need = num_envs * model.nbuffer
    if available and need > available:
        most = available // model.nbuffer
        raise BadInput(
            f"num_envs={num_envs} needs about {need / 2**30:.1f} GiB for MuJoCo's state buffers alone "
            f"({model.nbuffer / 2**10:.0f} kB each) but {available / 2**30:.1f} GiB are available; valid: num_envs "
            f"<= {most}"
        )


def _available_bytes() -> int | None:
    """MemAvailable of /proc/meminfo (Linux), else None."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


class BatchSim:
    """E copies of `model`, each advanced `decimation` physics steps per policy step.

    Args:
        model: the compiled model every env simulates.
        num_envs: number of parallel envs E.
        decimation: physics steps per policy step.
        nthread: threads of `mujoco.batch`; 0 for every core (never more than E).
    """

    def __init__(self, model: mujoco.MjModel, num_envs: int, decimation: int, nthread: int = 0):
        self.model = model
        self.num_envs = num_envs
        self.decimation = int(decimation)
        threads = nthread or os.cpu_count() or 1
        _check_memory(model, num_envs)
        try:
            self.batch = mjb.Batch(model, nsim=num_envs, nthread=min(threads, num_envs))
        except (MemoryError, ValueError) as err:  # MuJoCo's std::bad_alloc arrives as a ValueError
            if not isinstance(err, MemoryError) and "alloc" not in str(err):
                raise
            each_mb = (model.narena + model.nbuffer) / 2**20  # what every simulation reserves
            raise BadInput(
                f"num_envs={num_envs}: MuJoCo could not allocate {num_envs} simulations of {each_mb:.1f} MB each "
                f"({num_envs * each_mb / 2**10:.0f} GB; {err}); valid: fewer envs"
            ) from None
        self.qpos, self.qvel, self.ctrl = self.batch.bind("qpos"), self.batch.bind("qvel"), self.batch.bind("ctrl")
        self._bad_states = np.zeros(num_envs, dtype=np.int64)  # BAD_STATE_WARNINGS counted since each env's reset

    @property
    def dt(self) -> float:
        """Policy step, s: timestep * decimation."""
        return float(self.model.opt.timestep) * self.decimation

    def advance(self, substep=None) -> np.ndarray:
        """Step every env `decimation` physics steps with the current controls; `substep()`, when given, is called
        after each physics step (a probe reading contacts, which a policy step's last state alone would undersample).

        Returns:
            Env ids whose simulation failed (diverged): an error, or a state MuJoCo found bad and reset to the model's
            defaults (`BAD_STATE_WARNINGS`). Their state is left for the caller to reset. Shape: (n,).
        """
        try:
            if substep is None:
                self.batch.step(nstep=self.decimation)
            else:
                for _ in range(self.decimation):
                    self.batch.step(nstep=1)
                    substep()
            failed = np.empty(0, dtype=np.int64)
        except mjb.SimulationError as err:
            failed = np.asarray(err.ids, dtype=np.int64)
        bad_states = self.batch.warning[:, BAD_STATE_WARNINGS, 1].sum(-1)
        reset_by_mujoco = np.flatnonzero(bad_states > self._bad_states)
        self._bad_states = bad_states
        return np.union1d(failed, reset_by_mujoco) if len(reset_by_mujoco) else failed

    def restart(self, ids: np.ndarray) -> None:
        """Put envs `ids` back to the model's initial state, before the caller writes their new start."""
        self.batch.reset(ids, stage=mujoco.mjtStage.mjSTAGE_NONE)
        self._bad_states[ids] = 0

    def forward(self, ids: np.ndarray) -> None:
        """Recompute the derived quantities (positions, contacts) of envs `ids` after their state was written."""
        self.batch.forward(ids)
