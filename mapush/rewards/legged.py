"""The locomotion level's reward terms (`level=locomotion`): the usual legged ones. Each returns the unweighted term,
(num_envs, 1).

Terms read `LocomotionEnv`'s `state` after the physics step (body-frame `lin_vel`, `ang_vel`, `gravity`, `torques`,
foot contacts and speeds), and the env's `commands`, `actions` / `last_actions`, landings and exception flag.
"""

from __future__ import annotations

import torch


def _column(value: torch.Tensor) -> torch.Tensor:
    return value.float().unsqueeze(-1)


def lin_vel_tracking(env, sigma: float) -> torch.Tensor:
    """exp(-|v_cmd - v|^2 / sigma) over the planar body-frame velocity (m/s)."""
    error = ((env.commands[:, :2] - env.state.lin_vel[:, :2]) ** 2).sum(-1)
    return _column(torch.exp(-error / sigma))


def yaw_rate_tracking(env, sigma: float) -> torch.Tensor:
    """exp(-(w_cmd - w_z)^2 / sigma), yaw rate in rad/s."""
    return _column(torch.exp(-((env.commands[:, 2] - env.state.ang_vel[:, 2]) ** 2) / sigma))


def vertical_velocity(env) -> torch.Tensor:
    """v_z^2, (m/s)^2: bouncing."""
    return _column(env.state.lin_vel[:, 2] ** 2)


def roll_pitch_rate(env) -> torch.Tensor:
    """w_x^2 + w_y^2, (rad/s)^2: rocking."""
    return _column((env.state.ang_vel[:, :2] ** 2).sum(-1))


def tilt(env) -> torch.Tensor:
    """g_x^2 + g_y^2 of the body-frame gravity direction: 0 upright, sin^2 of the tilt angle."""
    return _column((env.state.gravity[:, :2] ** 2).sum(-1))


def joint_torques(env) -> torch.Tensor:
    """Sum of squared joint torques, (N m)^2."""
    return _column((env.state.torques**2).sum(-1))


def action_rate(env) -> torch.Tensor:
    """Sum of squared changes of the actions since the last step."""
    return _column(((env.actions - env.last_actions) ** 2).sum(-1))


def foot_slip(env) -> torch.Tensor:
    """Sum over feet on the ground of their squared planar speed, (m/s)^2."""
    return _column((env.state.feet_speed**2 * env.state.foot_contact).sum(-1))


def feet_air_time(env, target_s: float) -> torch.Tensor:
    """Sum over feet landing this step of (time in the air - target_s); 0 when the command is to stand still."""
    moving = torch.linalg.vector_norm(env.commands[:, :2], dim=-1) > 0.1
    landed = ((env.landed_air_time - target_s) * env.first_contact).sum(-1)
    return _column(landed * moving)


def fall(env) -> torch.Tensor:
    """1 on the step the robot falls (the episode ends)."""
    return _column(env.exception)
