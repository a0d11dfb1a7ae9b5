"""A frozen mid-level policy for the high level: the actor of a mid run's checkpoint, checked to fit its task."""

from __future__ import annotations

from pathlib import Path

import torch

from mapush.envs.mid import commands_from_actions
from mapush.envs.observations import local_dim
from mapush.errors import BadInput
from mapush.rl.policy import load_policy


class FrozenMid:
    """The mid level's deterministic actor (normalizer included), turned into robot commands.

    Args:
        policy: local observations (n, d) -> actions (n, 3).
        action_scale: the mid level's (vx, vy, yaw rate) scale of the clipped actions.
        action_gain: the mid level's gain on its raw actions before the clip.
        checkpoint: where it came from.
    """

    def __init__(self, policy, action_scale: torch.Tensor, action_gain: float, checkpoint: Path):
        self.policy, self.checkpoint = policy, checkpoint
        self.action_scale, self.action_gain = action_scale, action_gain

    def commands(self, local_obs: torch.Tensor) -> torch.Tensor:
        """Velocity commands (E, A, 3) from the robots' local observations (E, A, d)."""
        E, A, d = local_obs.shape
        with torch.inference_mode():
            actions = self.policy(local_obs.reshape(E * A, d))
        return commands_from_actions(actions.reshape(E, A, 3), self.action_gain, self.action_scale)


def load_mid_policy(target: str | Path | None, task_cfg: dict, level: str = "mid") -> FrozenMid:
    """The frozen level of `target` (a run dir of `level`: its latest checkpoint; or a model_<it>.pt in one).

    Raises BadInput when `target` is missing, is a run of another level, or was trained on another task or agent
    count.
    """
    if target in (None, "", "None"):
        raise BadInput("level=high needs the frozen mid level: mid=RUN_DIR (a mid-level run dir or model_<it>.pt)")
    policy = load_policy(target)
    mid_cfg = policy.cfg
    if mid_cfg["level"]["name"] != level:
        raise BadInput(f"mid={str(target)!r} is a {mid_cfg['level']['name']}-level run; valid: a {level}-level run dir")
    trained = (mid_cfg["task"]["name"], mid_cfg["task"]["num_agents"])
    wanted = (task_cfg["name"], task_cfg["num_agents"])
    if trained != wanted or policy.obs_dim != local_dim(wanted[1]):
        raise BadInput(
            f"mid={str(target)!r} was trained on task {trained[0]} with {trained[1]} agents, not {wanted[0]} with "
            f"{wanted[1]}; valid: a mid run of task={wanted[0]} task.num_agents={wanted[1]}"
        )
    scale = torch.tensor(mid_cfg["level"]["action_scale"], dtype=torch.float32)
    return FrozenMid(policy.actor, scale, float(mid_cfg["level"]["action_gain"]), policy.checkpoint)
