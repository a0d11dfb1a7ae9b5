"""`robot_contact`, the levels' `robot_collision`: robots that touch end an episode on every low level (the
original's centre distance, 0.25 m, is narrower than the tracker's footprint and never fires)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
import torch
from stand_ins import face_two_robots, stand_in_env

from mapush.config import compose_config, to_plain
from mapush.envs import terminations
from mapush.envs.mid import MidPushEnv

SIZE = (0.65, 0.28)  # lowlevel.size: the footprint's length and width, m
TOLERANCE = 0.02


def _box(x: float, y: float, yaw: float) -> shapely.Polygon:
    """The footprint as shapely draws it: the oracle."""
    box = shapely.box(-SIZE[0] / 2, -SIZE[1] / 2, SIZE[0] / 2, SIZE[1] / 2)
    return shapely.affinity.translate(shapely.affinity.rotate(box, yaw, use_radians=True), x, y)


def test_robot_contact_agrees_with_shapely_on_random_pairs():
    """No touching pair is missed; a pair taken for touching is within sqrt(2) x the tolerance (the separating-
    axis gap is a lower bound of the distance, exact face to face)."""
    rng = np.random.default_rng(0)
    n = 2000
    xy = torch.from_numpy(rng.uniform(-0.6, 0.6, (n, 2, 2))).float()
    yaw = torch.from_numpy(rng.uniform(-math.pi, math.pi, (n, 2))).float()
    env = stand_in_env(robot_xy=xy, robot_yaw=yaw, num_agents=2, cfg={"lowlevel": {"size": [*SIZE, 0.3]}})
    fired = terminations.robot_contact(env, TOLERANCE).numpy()
    poses = [(xy[k].tolist(), yaw[k].tolist()) for k in range(n)]
    distance = np.array([_box(*p[0], y[0]).distance(_box(*p[1], y[1])) for p, y in poses])
    assert fired[distance < TOLERANCE].all()
    assert (distance[fired] < math.sqrt(2) * TOLERANCE + 1e-5).all()
    assert 100 < fired.sum() < n - 100  # both outcomes are tried


def test_robots_side_by_side_touch_where_their_centres_are_further_than_robot_collision_s_distance():
    xy = torch.tensor([[[0.0, 0.0], [0.0, 0.29]], [[0.0, 0.0], [0.0, 0.40]]])  # 1 cm apart; 12 cm apart
    env = stand_in_env(robot_xy=xy, robot_yaw=torch.zeros(2, 2), num_agents=2, cfg={"lowlevel": {"size": [*SIZE]}})
    assert terminations.robot_contact(env, TOLERANCE).tolist() == [True, False]
    env.state.robot_distance = torch.linalg.vector_norm(xy.unsqueeze(2) - xy.unsqueeze(1), dim=-1)
    assert terminations.robot_collision(env, 0.25).tolist() == [False, False]


@pytest.mark.parametrize("lowlevel", ["tracker", "go1"])
def test_two_robots_driven_into_each_other_end_the_episode_with_robot_collision(lowlevel):
    """Two robots 2 m apart, facing each other, far from the object, both commanded forward at full speed: their
    footprints touch within 4 s and the mid level ends the episode with `robot_collision`; their centres never come
    within the original's 0.25 m."""
    cfg = to_plain(compose_config(["debug=smoke", f"lowlevel={lowlevel}", "num_envs=1", "level.episode_length_s=20"]))
    env = MidPushEnv(cfg, num_envs=1)
    face_two_robots(env)
    forward = torch.tensor([[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]])  # vx in each robot's frame
    touched_at = None
    for step in range(int(4.0 / env.dt)):
        env.step(forward)
        centres = torch.linalg.vector_norm(env.state.robot_xy[0, 0] - env.state.robot_xy[0, 1]).item()
        assert centres > 0.25
        if env.exception.any():
            touched_at = step * env.dt
            assert env.exception_names[int(env.exception_kind[0])] == "robot_collision"  # (the env has reset)
            break
    assert touched_at is not None and touched_at > 0.5  # they had 2 m to cover
