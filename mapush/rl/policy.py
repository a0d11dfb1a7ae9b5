"""A run's deterministic policy, built from its checkpoint's actor without an env or a runner.

The actor is rsl-rl's own model class, made from the run's `algo.actor` config and loaded with the checkpoint's
weights (normalizer included); its deterministic output is what `policy.pt` holds. The frozen mid level, the
Python API and evaluations of shipped policies all load through here.
"""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import NamedTuple

import torch
from rsl_rl.utils import resolve_class
from tensordict import TensorDict

from mapush.config import load_run_config, to_plain
from mapush.digests import verify
from mapush.errors import BadInput
from mapush.rundir import resolve_checkpoint
from mapush.trust import check_class_names


class Policy(NamedTuple):
    """A loaded policy: `actor(obs (n, obs_dim)) -> actions (n, action_dim)`, deterministic, on the CPU."""

    actor: torch.nn.Module
    obs_dim: int
    action_dim: int
    cfg: dict
    """The run's composed config."""
    checkpoint: Path


def read_checkpoint(path: Path) -> dict:
    """A checkpoint's tensors, loaded as weights only; BadInput for anything else (it could run code), or for a
    shipped checkpoint altered since it was shipped (`mapush.digests`)."""
    verify(path)
    try:
        return torch.load(path, weights_only=True, map_location="cpu")
    except pickle.UnpicklingError:
        raise BadInput(
            f"checkpoint {str(path)!r} holds objects other than weights and was not loaded (loading it could run "
            "code); valid: a checkpoint of tensors, numbers and strings, as mapush writes"
        ) from None
    except Exception as err:  # a truncated or foreign file
        raise BadInput(f"checkpoint {str(path)!r} is not an rsl-rl checkpoint ({type(err).__name__})") from None


def actor_shape(checkpoint: dict) -> tuple[int, int]:
    """(observation width, action width) of a checkpoint's actor: its first and last linear layers."""
    try:
        weights = [v for k, v in checkpoint["actor_state_dict"].items() if k.endswith("weight") and v.dim() == 2]
        return int(weights[0].shape[1]), int(weights[-1].shape[0])
    except (KeyError, IndexError, AttributeError, TypeError):
        raise BadInput("the checkpoint holds no rsl-rl actor (actor_state_dict); valid: a mapush checkpoint") from None


def actor_from_checkpoint(algo_cfg: dict, checkpoint: dict) -> torch.nn.Module:
    """The deterministic actor (rsl-rl's exportable MLP, normalizer included) of a checkpoint, in eval mode."""
    obs_dim, action_dim = actor_shape(checkpoint)
    check_class_names("algo.actor", algo_cfg["actor"])  # a run dir's config is data: no code from elsewhere
    actor_class, actor_cfg = resolve_class(algo_cfg["actor"])
    group = "policy"
    obs = TensorDict({group: torch.zeros(1, obs_dim)}, batch_size=[1])
    model = actor_class(obs, {"actor": [group]}, "actor", action_dim, **actor_cfg)
    try:
        model.load_state_dict(checkpoint["actor_state_dict"])
    except RuntimeError as err:
        raise BadInput(f"the checkpoint's actor does not fit the run's algo.actor config ({err})") from None
    return model.as_jit().eval()


def load_policy(target: str | Path) -> Policy:
    """The policy of a run dir (its latest checkpoint) or of a `model_<it>.pt` in one; BadInput if neither."""
    run_dir, checkpoint = resolve_checkpoint(Path(target))
    cfg = to_plain(load_run_config(run_dir))
    data = read_checkpoint(checkpoint)
    obs_dim, action_dim = actor_shape(data)
    return Policy(actor_from_checkpoint(cfg["algo"], data), obs_dim, action_dim, cfg, checkpoint)
