"""Observation terms: the mid level's local view (actor) and global state (critic), the high level's centralized
view, and the H+L robots' own parts. Levels name them in `level.observations`; each returns (E, rows, d), or (E, d)
shared by every policy row (`EnvCore.observations`).

Angles are encoded as (cos, sin) pairs, so the policy never sees the 2 pi jump of a wrapped angle.
"""

from __future__ import annotations

import torch

from mapush.planning.geometry import point_distance, rotate


def to_agent_frame(points: torch.Tensor, robot_xy: torch.Tensor, robot_yaw: torch.Tensor) -> torch.Tensor:
    """x^i = R(-yaw_i) (x - p_i) for points (E, A, ..., 2) seen by robot i at robot_xy (E, A, 2), yaw (E, A)."""
    extra = points.dim() - 3
    rel = points - robot_xy.view(*robot_xy.shape[:2], *(1,) * extra, 2)
    return rotate(rel, robot_yaw, inverse=True)


def angle_features(angle: torch.Tensor) -> torch.Tensor:
    """(cos, sin) of an angle: shape (...) -> (..., 2)."""
    return torch.stack([torch.cos(angle), torch.sin(angle)], -1)


def local_dim(num_agents: int) -> int:
    """Width of the local observation: 6 + 4 (A - 1)."""
    return 6 + 4 * (num_agents - 1)


def agents_for_local_dim(dim: int) -> int:
    """The agent count whose local observation is `dim` wide (inverse of `local_dim`)."""
    return (dim - 6) // 4 + 1


def local_observation(env) -> torch.Tensor:
    """Each robot's view in its own frame (paper III-C; original layout, angles as cos/sin).

    Layout (width 6 + 4 (A - 1)):
        subgoal xy (2) | object xy (2) | object yaw - own yaw (cos, sin) (2) |
        for k = 1..A-1, robot j = (i + k) mod A: its xy (2) and yaw - own yaw (cos, sin) (2)

    Returns:
        Shape: (E, A, 6 + 4 (A - 1)).
    """
    E, A = env.num_envs, env.num_agents
    xy, yaw = env.state.robot_xy, env.state.robot_yaw
    subgoal = to_agent_frame(env.subgoal_xy.unsqueeze(1).expand(E, A, 2), xy, yaw)
    obj = to_agent_frame(env.state.object_xy.unsqueeze(1).expand(E, A, 2), xy, yaw)
    parts = [subgoal, obj, angle_features(env.state.object_yaw.unsqueeze(1) - yaw)]
    if A > 1:
        others = env.other_agents  # (A, A-1)
        other_xy = to_agent_frame(xy[:, others], xy, yaw)  # (E, A, A-1, 2)
        other_yaw = angle_features(yaw[:, others] - yaw.unsqueeze(-1))  # (E, A, A-1, 2)
        parts.append(torch.cat([other_xy, other_yaw], -1).flatten(2))
    return torch.cat(parts, -1)


def global_dim(num_agents: int) -> int:
    """Width of the critic's global observation: 10 + 8 A."""
    return 10 + 8 * num_agents


def global_observation(env) -> torch.Tensor:
    """The whole state in the world frame, the same for every robot but for its one-hot id (MAPPO critic).

    Layout (width 10 + 8 A):
        object xy (2) | object yaw (cos, sin) (2) | object velocity vx, vy, yaw rate (3) | subgoal xy (2) |
        robots' xy (2 A) | robots' yaw (cos, sin) (2 A) | robots' velocity (3 A) | episode time fraction (1) |
        agent one-hot (A)

    Returns:
        Shape: (E, A, 10 + 8 A).
    """
    E, A = env.num_envs, env.num_agents
    state = torch.cat(
        [
            env.state.object_xy,
            angle_features(env.state.object_yaw),
            env.state.object_vel,
            env.subgoal_xy,
            env.state.robot_xy.flatten(1),
            angle_features(env.state.robot_yaw).flatten(1),
            env.state.robot_vel.flatten(1),
            (env.episode_step.float() / env.max_episode_length).unsqueeze(1),
        ],
        -1,
    )
    return torch.cat([state.unsqueeze(1).expand(E, A, -1), env.agent_one_hot.expand(E, A, A)], -1)


def target_heading(env) -> torch.Tensor:
    """Direction from the object to the final target, rad (E,): the x axis of the target frame."""
    to_target = env.target_xy - env.state.object_xy
    return torch.atan2(to_target[:, 1], to_target[:, 0])


def high_observation(env) -> torch.Tensor:
    """The centralized high-level view in the target frame (origin at the object, x toward the final target).

    Layout (width 8 + 4 A + 2 L + 3 M, L = len(observe.path_ahead_m), M = observe.obstacles):
        target distance (1) | object yaw (cos, sin) (2) | object velocity vx, vy (2) | current subgoal xy (2) |
        robots' xy (2 A) | robots' yaw (cos, sin) (2 A) | path points ahead xy (2 L) |
        nearest obstacles: centre xy and footprint distance to the object centre (3 M), nearest first |
        episode time fraction (1)
    """
    observe = env.cfg["level"]["observe"]
    heading = target_heading(env)

    def frame(points: torch.Tensor) -> torch.Tensor:  # (E, ..., 2) world -> target frame
        return rotate(points - env.state.object_xy.view(env.num_envs, *(1,) * (points.dim() - 2), 2), -heading)

    vel_frame = rotate(env.state.object_vel[:, :2], -heading)
    ahead = env.path_points_ahead(torch.tensor(observe["path_ahead_m"], dtype=torch.float32))
    parts = [
        env.target_distance.unsqueeze(-1),
        angle_features(env.state.object_yaw - heading),
        vel_frame,
        frame(env.subgoal_xy.unsqueeze(1)).flatten(1),
        frame(env.state.robot_xy).flatten(1),
        angle_features(env.state.robot_yaw - heading.unsqueeze(1)).flatten(1),
        frame(ahead).flatten(1),
    ]
    m = observe["obstacles"]
    if m:
        if env.num_obstacles:
            dist = point_distance(env.state.object_xy.unsqueeze(1), env.obstacles).squeeze(1)  # (E, K)
            order = dist.argsort(-1)[:, :m]
            centres = env.obstacles[..., :2].gather(1, order.unsqueeze(-1).expand(-1, -1, 2))
            near = torch.cat(
                [frame(centres).clamp(-20.0, 20.0), dist.gather(1, order).clamp(max=20.0).unsqueeze(-1)], -1
            )
        else:
            near = torch.zeros(env.num_envs, 0, 3)
        if near.shape[1] < m:  # fewer obstacles than observed slots: far away, straight behind
            pad = torch.zeros(env.num_envs, m - near.shape[1], 3)
            pad[..., 0], pad[..., 2] = -20.0, 20.0
            near = torch.cat([near, pad], 1)
        parts.append(near.flatten(1))
    parts.append((env.episode_step.float() / env.max_episode_length).unsqueeze(-1))
    return torch.cat(parts, -1)


def high_obs_dim(cfg: dict) -> int:
    """Width of `high_observation` for a config."""
    observe = cfg["level"]["observe"]
    return 8 + 4 * cfg["task"]["num_agents"] + 2 * len(observe["path_ahead_m"]) + 3 * observe["obstacles"]


def own_pose_target_frame(env) -> torch.Tensor:
    """Each robot's xy relative to the object and its yaw (cos, sin), in the target frame: (E, A, 4)."""
    heading = target_heading(env)
    own_xy = rotate(env.state.robot_xy - env.state.object_xy.unsqueeze(1), -heading)
    own_yaw = angle_features(env.state.robot_yaw - heading.unsqueeze(1))
    return torch.cat([own_xy, own_yaw], -1)


def own_goal_target_frame(env) -> torch.Tensor:
    """Each robot's navigation goal relative to it, in the target frame: (E, A, 2)."""
    return rotate(env.robot_goal_xy - env.state.robot_xy, -target_heading(env))


def object_log_mass(env) -> torch.Tensor:
    """The object's mass as ln(kg), shared by every robot: (E, 1). For a policy trained over a range of masses (the
    team study), which cannot tell them apart otherwise; log, as the range is drawn log-uniformly."""
    return torch.log(torch.as_tensor(env.sim.object_masses(), dtype=torch.float32)).unsqueeze(-1)


def agent_one_hot(env) -> torch.Tensor:
    """Each robot's one-hot index: (E, A, A)."""
    return env.agent_one_hot.expand(env.num_envs, -1, -1)
