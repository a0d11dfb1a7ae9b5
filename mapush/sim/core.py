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

BAD_STATE_WARNINGS = [
    int(mujoco.mjtWarning.mjWARN_BADQPOS),
    int(mujoco.mjtWarning.mjWARN_BADQVEL),
    int(mujoco.mjtWarning.mjWARN_BADQACC),
]
"""MuJoCo's warnings for a NaN, infinite or huge state: it then resets that sim to the model's defaults and steps
on, so the state read afterwards is finite again and only these counters tell that the sim diverged."""


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
        self.batch = mjb.Batch(model, nsim=num_envs, nthread=min(threads, num_envs))
        self.qpos, self.qvel, self.ctrl = self.batch.bind("qpos"), self.batch.bind("qvel"), self.batch.bind("ctrl")
        self._bad_states = np.zeros(num_envs, dtype=np.int64)  # BAD_STATE_WARNINGS counted since each env's reset

    @property
    def dt(self) -> float:
        """Policy step, s: timestep * decimation."""
        return float(self.model.opt.timestep) * self.decimation

    def advance(self) -> np.ndarray:
        """Step every env `decimation` physics steps with the current controls.

        Returns:
            Env ids whose simulation failed (diverged): an error, or a state MuJoCo found bad and reset to the model's
            defaults (`BAD_STATE_WARNINGS`). Their state is left for the caller to reset. Shape: (n,).
        """
        try:
            self.batch.step(nstep=self.decimation)
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
