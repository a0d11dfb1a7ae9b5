"""A frozen mid-level policy for the high level: loaded from a mid run dir or checkpoint, checked to fit."""

from __future__ import annotations

import tempfile
from pathlib import Path

import torch

from mapush.config import load_run_config, to_plain
from mapush.envs.observations import local_dim
from mapush.errors import BadInput


class FrozenMid:
    """The mid level's deterministic actor as TorchScript (normalizer included), turned into robot commands.

    Args:
        policy: local observations (n, d) -> actions (n, 3).
        action_scale: the mid level's (vx, vy, yaw rate) scale of the clipped actions.
        checkpoint: where it came from.
    """

    def __init__(self, policy, action_scale: torch.Tensor, checkpoint: Path):
        self.policy, self.action_scale, self.checkpoint = policy, action_scale, checkpoint

    def commands(self, local_obs: torch.Tensor) -> torch.Tensor:
        """Velocity commands (E, A, 3) from the robots' local observations (E, A, d)."""
        E, A, d = local_obs.shape
        with torch.inference_mode():
            actions = self.policy(local_obs.reshape(E * A, d))
        return actions.reshape(E, A, 3).clamp(-1.0, 1.0) * self.action_scale


def load_mid_policy(target: str | Path | None, task_cfg: dict) -> FrozenMid:
    """The mid level of `target` (a mid run dir: its latest checkpoint; or a model_<it>.pt in one).

    Raises BadInput when `target` is missing, is not a mid-level run, or was trained on another task or agent count.
    """
    from mapush.eval.rollout import resolve_checkpoint  # late: rollout builds envs through mapush.train
    from mapush.rl.runner import load_checkpoint
    from mapush.train import build

    if target in (None, "", "None"):
        raise BadInput("level=high needs the frozen mid level: mid=RUN_DIR (a mid-level run dir or model_<it>.pt)")
    run_dir, checkpoint = resolve_checkpoint(Path(target))
    mid_cfg = to_plain(load_run_config(run_dir))
    if mid_cfg["level"]["name"] != "mid":
        raise BadInput(f"mid={str(target)!r} is a {mid_cfg['level']['name']}-level run; valid: a mid-level run dir")
    trained = (mid_cfg["task"]["name"], mid_cfg["task"]["num_agents"])
    wanted = (task_cfg["name"], task_cfg["num_agents"])
    if trained != wanted:
        raise BadInput(
            f"mid={str(target)!r} was trained on task {trained[0]} with {trained[1]} agents, not {wanted[0]} with "
            f"{wanted[1]}; valid: a mid run of task={wanted[0]} task.num_agents={wanted[1]}"
        )
    mid_cfg["num_envs"] = 1
    _, runner = build(mid_cfg, None, 0)
    load_checkpoint(runner, checkpoint, local_dim(wanted[1]), f"task {wanted[0]} with {wanted[1]} agents")
    with tempfile.TemporaryDirectory() as tmp:
        runner.export_policy_to_jit(tmp, "mid.pt")
        policy = torch.jit.load(str(Path(tmp) / "mid.pt"))
    policy.eval()
    scale = torch.tensor(mid_cfg["level"]["action_scale"], dtype=torch.float32)
    return FrozenMid(policy, scale, checkpoint)
