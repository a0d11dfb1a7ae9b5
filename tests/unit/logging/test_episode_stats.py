"""`mapush logs episodes`: episodes read back from real recordings, and their statistics against hand geometry
and GEOS (shapely)."""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest
import shapely
import torch
from conftest import MAPUSH, composed
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

from mapush.envs.mid import MidPushEnv
from mapush.logging.episode_stats import JAM_M, TOUCH_M, Track, _scene_geometry, episode_stats, read_tracks
from mapush.logging.episodes import EpisodeRecorder
from mapush.logging.foxglove_scene import SceneLayout, scene_update
from mapush.planning.geometry import corners


class ObjectProbe:
    """A second recorder on the env: the raw simulated object pose at every step the episode recorder sees."""

    def __init__(self):
        self.xy: list[np.ndarray] = []
        self.robot_xy: list[np.ndarray] = []

    def capture(self, env, commands, reward, parts, done) -> None:
        self.xy.append(env.state.object_xy[0].numpy().copy())
        self.robot_xy.append(env.state.robot_xy[0].numpy().copy())


def track(xy, path=None, obstacles=(), hull=None, yaw=None, dt=0.02, outcome="timeout", robots=None) -> Track:
    xy = np.asarray(xy, dtype=float)
    square = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    return Track(
        end={"outcome": outcome, "exception": "", "time_s": dt * len(xy)},
        dt=dt,
        object_xy=xy,
        object_yaw=np.zeros(len(xy)) if yaw is None else np.asarray(yaw, dtype=float),
        robot_xy=np.zeros((len(xy), 0, 2)) if robots is None else np.asarray(robots, dtype=float),
        hull=square if hull is None else hull,
        path=None if path is None else np.asarray(path, dtype=float),
        goal_xy=np.array([10.0, 0.0]),
        obstacles=np.asarray(obstacles, dtype=float).reshape(-1, 5),
    )


def test_a_straight_push_beside_the_path():
    """0.2 m/s along x for 2 s, 0.3 m beside a straight path, then 1 s standing still."""
    moving = np.stack([np.arange(101) * 0.004, np.full(101, 0.3)], 1)
    still = np.repeat(moving[-1:], 50, axis=0)
    path = np.stack([np.linspace(0.0, 10.0, 2501), np.zeros(2501)], 1)  # spaced 4 mm: every pose has its foot
    row = episode_stats(track(np.concatenate([moving, still]), path=path))
    assert row["travel_m"] == pytest.approx(0.4)
    assert row["net_m"] == pytest.approx(math.hypot(0.4, 0.0))
    assert row["path_m"] == pytest.approx(10.0)
    assert row["off_path_m"] == pytest.approx(0.3)
    assert row["off_path_max_m"] == pytest.approx(0.3)
    assert row["stalled"] == pytest.approx(50 / 150)  # 150 steps between 151 poses; the last 50 still
    assert row["speed"] == pytest.approx(0.4 / 150 / 0.02)
    assert row["goal_m"] == pytest.approx(math.hypot(10.0 - 0.4, 0.3))
    assert row["touching"] == 0.0 and math.isnan(episode_stats(track(moving))["path_m"])
    assert row["jammed"] == 0.0  # no robots recorded


def test_jammed_counts_the_still_steps_with_two_robots_body_to_body():
    """Three robots; the object moves for 100 steps, then stands for 50. Robots 0 and 1 come within 0.5 m of each
    other after step 80 and stay; robot 2 keeps 3 m away. Jammed: the still steps with a close pair, 50 of 150."""
    moving = np.stack([np.arange(101) * 0.004, np.zeros(101)], 1)
    xy = np.concatenate([moving, np.repeat(moving[-1:], 50, axis=0)])  # 151 poses, 150 steps
    gap = np.where(np.arange(151) > 80, 0.5, 2.0)
    robots = np.stack([np.stack([-gap / 2, np.full(151, -1.0)], 1), np.stack([gap / 2, np.full(151, -1.0)], 1)], 1)
    robots = np.concatenate([robots, np.tile([[3.0, 3.0]], (151, 1, 1))], 1)  # (151, 3, 2)
    assert episode_stats(track(xy, robots=robots))["jammed"] == pytest.approx(50 / 150)
    apart = robots.copy()
    apart[:, 1, 0] = apart[:, 0, 0] + JAM_M + 0.01  # the same stall with the pair just beyond JAM_M
    assert episode_stats(track(xy, robots=apart))["jammed"] == 0.0


def test_a_wandering_push_travels_further_than_it_gets():
    """Back and forth along x: 4 legs of 1 m end 0 m from the start."""
    legs = np.concatenate([np.linspace(0, 1, 51), np.linspace(1, 0, 51)[1:], np.linspace(0, 1, 51)[1:]])
    legs = np.concatenate([legs, np.linspace(1, 0, 51)[1:]])
    row = episode_stats(track(np.stack([legs, np.zeros_like(legs)], 1)))
    assert row["travel_m"] == pytest.approx(4.0)
    assert row["net_m"] == pytest.approx(0.0, abs=1e-12)


def test_touching_agrees_with_geos():
    """A cylinder's footprint (64-gon, r = 1.5) passes rotated blocks: contact as GEOS measures the distance."""
    gen = np.random.default_rng(0)
    angles = np.linspace(0.0, 2 * np.pi, 64, endpoint=False)
    hull = 1.5 * np.stack([np.cos(angles), np.sin(angles)], 1)
    xy = np.stack([np.linspace(-4.0, 4.0, 400), gen.uniform(-0.3, 0.3, 400)], 1)
    yaw = gen.uniform(-np.pi, np.pi, 400)
    blocks = np.array([[0.0, 2.05, 0.3, 1.0, 1.0], [2.5, -2.3, -0.7, 1.0, 0.6], [-3.0, 1.9, 0.0, 0.5, 0.5]])
    row = episode_stats(track(xy, obstacles=blocks, hull=hull, yaw=yaw))
    squares = [shapely.Polygon(c) for c in corners(torch.as_tensor(blocks)).numpy()]
    distance = []
    for (x, y), turn in zip(xy, yaw, strict=True):
        c, s = math.cos(turn), math.sin(turn)
        footprint = shapely.Polygon(hull @ np.array([[c, s], [-s, c]]) + [x, y])
        distance.append(min(footprint.distance(square) for square in squares))
    distance = np.array(distance)
    # The separating-axis gap is a lower bound of the distance, exact up to the 64-gon's chords here: allow 1 cm
    assert np.mean(distance < TOUCH_M) <= row["touching"] <= np.mean(distance < TOUCH_M + 0.01)
    assert 0.05 < row["touching"] < 0.95  # the trajectory both touches and clears the blocks


def test_the_scene_gives_back_what_it_drew():
    """Object footprint, target, path and blocks decoded from the writer's own `/scene` message."""
    cfg = composed("task=tblock")
    layout = SceneLayout.from_config(cfg)
    rows = torch.tensor([[2.0, 1.0, 0.4, 1.0, 0.5], [-1.0, -3.0, -1.2, 0.8, 0.8]])
    path = np.stack([np.linspace(-5.0, 6.0, 32), np.sin(np.linspace(0, 3, 32))], 1)
    frame = {
        "subgoal_xy": np.array([1.0, 2.0]),
        "target_xy": np.array([6.0, 0.5]),
        "obstacles": corners(rows).numpy(),
        "path": path,
        "robot_xy": np.zeros((2, 2)),
        "robot_yaw": np.zeros(2),
    }
    got = _scene_geometry(SceneUpdate.FromString(scene_update(layout, frame, 0).encode()))  # as a file holds it
    np.testing.assert_allclose(corners(torch.as_tensor(got["obstacles"])).numpy(), corners(rows).numpy(), atol=1e-5)
    np.testing.assert_allclose(got["path"], path, atol=1e-6)
    np.testing.assert_allclose(got["goal_xy"], [6.0, 0.5], atol=1e-6)
    parts = cfg["task"]["object"]["parts"]
    boxes = [
        shapely.box(
            p["pos"][0] - p["size"][0] / 2,
            p["pos"][1] - p["size"][1] / 2,
            p["pos"][0] + p["size"][0] / 2,
            p["pos"][1] + p["size"][1] / 2,
        )
        for p in parts
    ]
    assert shapely.Polygon(got["hull"]).area == pytest.approx(shapely.union_all(boxes).convex_hull.area)


def test_a_recorded_episode_reads_back(tmp_path):
    """A real mid-level recording: every step's object pose, the outcome, and the step length, as simulated."""
    cfg = composed("task=cylinder", "task.num_agents=3", "level.episode_length_s=0.4")
    env = MidPushEnv(cfg, num_envs=2)
    path = tmp_path / "episodes.mcap"
    recorder = EpisodeRecorder(path, SceneLayout.from_config(cfg), list(env.rewards.terms), env.exception_names)
    recorder.watch([0], env.dt, "test", from_start=True)
    probe = ObjectProbe()
    env.recorders += [recorder, probe]
    actions = torch.tensor([[1.0, 0.0, 0.0], [1.0, 0.2, 0.0], [0.8, -0.2, 0.0]]).expand(2, 3, 3)
    for _ in range(25):
        env.step(actions)
    recorder.close()
    (got,) = read_tracks(path)
    steps = len(got.object_xy)
    assert steps == 20 and got.dt == pytest.approx(env.dt)
    np.testing.assert_allclose(got.object_xy, np.array(probe.xy[:steps]), atol=1e-5)
    np.testing.assert_allclose(got.robot_xy, np.array(probe.robot_xy[:steps]), atol=1e-5)  # (20, 3, 2)
    assert got.end["outcome"] in {"success", "exception", "timeout"}
    out = subprocess.run([*MAPUSH, "logs", "episodes", str(path)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.count("\n") == 3 and got.end["outcome"] in out.stdout  # heading, rule, one episode


def test_a_file_without_episodes_is_refused(tmp_path):
    bad = tmp_path / "empty.mcap"
    bad.write_bytes(b"not an mcap")
    out = subprocess.run([*MAPUSH, "logs", "episodes", str(bad)], capture_output=True, text=True)
    assert out.returncode == 2 and "empty.mcap" in out.stderr and "valid:" in out.stderr
