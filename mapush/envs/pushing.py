"""What the pushing levels (mid, mid_long, high, high_nav) share on top of the env core: the low-level backend
driving A robots in a `PushSim`, the object's hull, the state (`PushState`), divergence, and what viewers draw."""

from __future__ import annotations

import numpy as np
import torch

from mapush.envs.base import EnvCore
from mapush.envs.events import EpisodeEvents
from mapush.envs.spawn_ring import check_spawn
from mapush.errors import BadInput
from mapush.lowlevel import BACKENDS, backend_name, backend_of
from mapush.planning.geometry import corners
from mapush.sim.push import PushSim, PushState
from mapush.sim.shapes import object_hull


class PushEnv(EnvCore):
    """E envs x A robots and one object each; obstacle blocks where the level has `level.obstacles`.

    Args:
        cfg: the composed config as a plain dict (task, level, lowlevel, reward, sim, seed).
        num_envs: overrides `cfg["num_envs"]` (eval and bench use their own counts).
        rows: policy rows per env.
        decision_steps: simulation steps per policy step (the high level's decisions hold several).
        evaluation: an evaluation env; a training env draws the robots' dynamics anew at every episode start where
            the backend has a `randomize` block (the tracker's `vary`).
    """

    state: PushState

    def __init__(self, cfg: dict, num_envs: int | None, rows: int, decision_steps: int = 1, evaluation: bool = False):
        self.validate(cfg)
        task = cfg["task"]
        E = num_envs or cfg["num_envs"]
        obstacles = cfg["level"].get("obstacles")  # the long-horizon map's blocks; none at the mid level
        blocks = {"obstacles": obstacles["count"], "obstacle_size": obstacles["size"]} if obstacles else {}
        self.num_obstacles = blocks.get("obstacles", 0)
        self.lowlevel = backend_of(cfg["lowlevel"])(cfg["lowlevel"])
        # under `level.fallen_robots: still` a robot that fell gets no commands: it lies where it fell, a body the
        # others can touch (the tracker's, held by its force-limited actuators; a Go1 has no `fallen` and lies as
        # its physics leaves it)
        self.still_fallen = cfg["level"].get("fallen_robots", "act") == "still"
        # counted where evaluated, with the thresholds of `eval.events`
        self.events = EpisodeEvents(E, task["num_agents"], cfg["eval"]["events"]) if evaluation else None
        sim = PushSim(cfg["sim"], task, self.lowlevel, E, **blocks)
        super().__init__(cfg, sim, E, task["num_agents"], rows, sim.dt * decision_steps)
        self.sim_dt = sim.dt
        self.hull = torch.tensor(object_hull(task["object"]), dtype=torch.float32)
        A = self.num_agents
        self.other_agents = (torch.arange(A).unsqueeze(1) + torch.arange(1, A).unsqueeze(0)) % A  # (A, A-1)
        self.agent_one_hot = torch.eye(A).unsqueeze(0)  # (1, A, A)
        self.subgoal_xy = torch.zeros(E, 2)
        self.obstacles = torch.zeros(E, self.num_obstacles, 5)  # (x, y, yaw, size x, size y) of each block
        self.obstacle_corners = torch.zeros(E, self.num_obstacles, 4, 2)  # their footprints, fixed per episode
        self.varied = not evaluation and bool(cfg["lowlevel"].get("randomize"))
        self.dynamics_rng = np.random.default_rng(int(cfg["seed"]))
        self.lowlevel.seed(int(cfg["seed"]))

    def seed(self, seed: int) -> None:
        """Reseed the start draws, the robots' dynamics included."""
        super().seed(seed)
        self.dynamics_rng = np.random.default_rng(int(seed))
        self.lowlevel.seed(int(seed))

    def reset(self, ids: np.ndarray) -> None:
        """Start new episodes in envs `ids`; in training, with robot dynamics drawn anew (`lowlevel.randomize`)."""
        if self.varied and len(ids):
            self.lowlevel.vary(self.sim.batch, ids, self.dynamics_rng)
        if self.events is not None:
            self.events.reset(torch.from_numpy(np.asarray(ids, dtype=np.int64)))
        super().reset(ids)

    def _advance(self, commands: torch.Tensor, live: torch.Tensor | None = None) -> np.ndarray:
        """One physics step of every env under `commands` (E, A, 3) (none for a robot that lies where it fell,
        `level.fallen_robots: still`), the state read and the episode's events counted in the envs `live` (E,)
        still running (default all); the env ids whose simulation failed."""
        fallen = getattr(self.lowlevel, "fallen", None)
        if self.still_fallen and fallen is not None:
            commands = commands * torch.from_numpy(~fallen).unsqueeze(-1)
        failed = self.sim.step(commands)
        self._read_state()
        if self.events is not None:
            self.events.update(self, torch.ones(self.num_envs, dtype=torch.bool) if live is None else live)
        return failed

    def episode_end(self, done: torch.Tensor, failed: torch.Tensor) -> dict[str, torch.Tensor]:
        """The env core's outcomes, and in evaluation the episode's events (`EpisodeEvents.counts`)."""
        end = super().episode_end(done, failed)
        if self.events is not None:
            end.update({name: torch.where(done, count, 0.0) for name, count in self.events.counts().items()})
        return end

    def set_obstacles(self, ids: np.ndarray, obstacles: torch.Tensor) -> None:
        """Place the obstacles (n, K, 5) of envs `ids`, in the simulation and in the env's geometry."""
        t = torch.from_numpy(ids)
        self.obstacles[t] = obstacles
        self.obstacle_corners[t] = corners(obstacles)
        self.sim.set_obstacles(ids, obstacles)

    @classmethod
    def validate(cls, cfg: dict) -> None:
        """Check a config before anything is built or written: low-level backend, agent count, spawn ring, terms."""
        if backend_name(cfg["lowlevel"]) not in BACKENDS:
            raise BadInput(f"unknown lowlevel backend {backend_name(cfg['lowlevel'])!r}; valid: {', '.join(BACKENDS)}")
        backend_of(cfg["lowlevel"]).check(cfg["lowlevel"])  # e.g. the go1 backend's policy must exist
        check_spawn(cfg)
        super().validate(cfg)

    def _read_state(self) -> None:
        self.state = self.sim.read()

    def _divergence(self, failed: np.ndarray) -> torch.Tensor:
        """(E,) envs whose simulation failed this step (`failed` ids) or whose state is no longer finite."""
        diverged = torch.zeros(self.num_envs, dtype=torch.bool)
        diverged[torch.from_numpy(failed)] = True
        finite = torch.isfinite(self.state.object_xy).all(-1) & torch.isfinite(self.state.robot_xy).flatten(1).all(-1)
        return diverged | ~finite

    def scene_frame(self) -> dict[str, torch.Tensor]:
        """What a viewer draws of every env now (before resets): poses (E, ...) and the subgoal (E, 2)."""
        s = self.state
        return {
            "object_xy": s.object_xy,
            "object_z": s.object_z,
            "object_yaw": s.object_yaw,
            "robot_xy": s.robot_xy,
            "robot_yaw": s.robot_yaw,
            "subgoal_xy": self.subgoal_xy,
        }
