"""The high-level env on a frozen mid level, its training through the CLI, and bad mid-level inputs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from mapush.envs.high import HighPushEnv
from mapush.envs.observations import high_obs_dim, local_dim
from mapush.planning.geometry import point_distance
from mapush.planning.paths import resample
from mapush.planning.planner import PlanResult
from mapush.rl.frozen import load_mid_policy
from mapush.sim.shapes import object_radius


@pytest.fixture(scope="module")
def mid(smoke_run):
    """The frozen mid level of the session's `debug=smoke` run (cuboid, 2 agents)."""
    from conftest import composed

    return load_mid_policy(smoke_run, composed("level=high")["task"])


@pytest.fixture
def high_cfg(cfg_for, smoke_run):
    return cfg_for("level=high", f"mid={smoke_run}", "level.episode_length_s=4")


class RecordingMid:
    """Wraps the frozen mid level and records every subgoal distance its observations show."""

    def __init__(self, mid):
        self.mid, self.subgoal_distances = mid, []

    def commands(self, local_obs: torch.Tensor) -> torch.Tensor:
        # local obs 0:2 = the subgoal in the robot's frame, 2:4 = the object; their difference's norm is the
        # object-subgoal distance the mid level is asked to close
        self.subgoal_distances.append(torch.linalg.vector_norm(local_obs[..., 0:2] - local_obs[..., 2:4], dim=-1))
        return self.mid.commands(local_obs)


def test_the_frozen_mid_level_drives_with_its_runs_action_gain(run_copy):
    from conftest import composed

    config = run_copy / "config.yaml"
    config.write_text(config.read_text().replace("action_gain: 1.0", "action_gain: 0.5"))
    frozen = load_mid_policy(run_copy, composed("level=high")["task"])
    obs = torch.randn(5, 2, local_dim(2), generator=torch.Generator().manual_seed(0)) * 3
    raw = frozen.policy(obs.reshape(10, -1)).reshape(5, 2, 3).detach()
    assert frozen.action_gain == 0.5
    assert torch.allclose(frozen.commands(obs), 0.5 * torch.clamp(0.5 * raw, -1.0, 1.0))  # action_scale 0.5


def test_step_shapes_and_no_nan(high_cfg, mid):
    env = HighPushEnv(high_cfg, mid, num_envs=3)
    obs = env.observations()
    assert obs["policy"].shape == (3, 1, high_obs_dim(high_cfg)) == obs["critic"].shape
    gen = torch.Generator().manual_seed(0)
    for _ in range(10):  # 4 s episodes of 0.5 s decisions: 8 decisions, so this crosses a reset
        obs, reward, terminated, truncated, _ = env.step(torch.rand(3, 1, 2, generator=gen) * 2 - 1)
        assert reward.shape == (3, 1) and terminated.shape == truncated.shape == (3,)
        assert torch.isfinite(obs["policy"]).all() and torch.isfinite(reward).all()
    assert env.max_episode_length == 8


def test_frozen_mid_level_gets_subgoals_inside_its_trained_range(high_cfg, mid):
    recording = RecordingMid(mid)
    env = HighPushEnv(high_cfg, recording, num_envs=4)
    for action in ([-1.0, -1.0], [1.0, 1.0], [0.0, 0.0], [0.5, -0.3]):
        recording.subgoal_distances.clear()
        env.step(torch.tensor(action).expand(4, 1, 2))
        first = recording.subgoal_distances[0]  # set this decision, before the object moved
        assert first.min().item() >= 1.5 - 1e-4 and first.max().item() <= 3.0 + 1e-4


def test_action_zero_follows_the_path_at_the_middle_distance(high_cfg, mid):
    env = HighPushEnv(high_cfg, mid, num_envs=2)
    direction = env.path_direction()
    subgoal = env.subgoal_from_action(torch.zeros(2, 2))
    assert torch.allclose(subgoal, env.state.object_xy + 2.25 * direction, atol=1e-5)


def test_follow_path_ignores_the_policy_and_keeps_every_subgoal_on_the_path(high_cfg, mid):
    high_cfg["level"]["follow_path"] = True
    env = HighPushEnv(high_cfg, mid, num_envs=2)
    expected = env.state.object_xy + 2.25 * env.path_direction()  # where the action (0, 0) puts the subgoal
    env._apply_action(torch.tensor([[[1.0, -1.0]], [[-0.5, 0.7]]]))
    assert torch.allclose(env.subgoal_xy, expected, atol=1e-5)


def test_a_planner_failure_ends_the_episode_as_a_failure(high_cfg, mid):
    class NoPath:
        def plan(self, start, goal, obstacles, waypoints):
            return PlanResult(None, solved=False, valid=False, planning_time_s=0.0, length_m=0.0)

    env = HighPushEnv(high_cfg, mid, num_envs=2, planner=NoPath())
    _, _, terminated, _, info = env.step(torch.zeros(2, 1, 2))
    assert terminated.all()
    assert info["episode_end"]["planner_failure"].all()
    assert not info["episode_end"]["success"].any()
    assert (info["episode_end"]["exception_kind"] == env.exception_names.index("planner_failure")).all()


@pytest.mark.parametrize("evaluation", [False, True])
@pytest.mark.slow
def test_training_plans_its_paths_on_evaluation_maps_unless_told_not_to(high_cfg, evaluation):
    from mapush.levels import make_env

    assert make_env(high_cfg, evaluation).planner is not None  # by default training plans too, as evaluation does
    high_cfg["level"]["path"]["plan_in_training"] = False  # the paper's curved training paths
    assert (make_env(high_cfg, evaluation).planner is None) != evaluation
    high_cfg["level"]["path"]["plan_in_training"] = True
    high_cfg["num_envs"] = 3
    env = make_env(high_cfg, evaluation)
    assert env.planner is not None and not env.plan_failed.any()
    start, goal = env.path[:, 0], env.path[:, -1]
    assert torch.allclose(start, env.state.object_xy, atol=1e-4) and torch.allclose(goal, env.target_xy, atol=1e-4)
    gap = point_distance(resample(env.path, 256), env.obstacles).amin(1)  # (E, K): the planned path's clearance
    assert (gap >= object_radius(high_cfg["task"]["object"]) - 1e-3).all()


def _obstacle_on_robot_0_of_env_0(env) -> None:
    obstacles = env.obstacles.clone()
    obstacles[0, 0, :2] = env.state.robot_xy[0, 0]
    obstacles[0, 0, 2] = 0.0
    env.set_obstacles(torch.arange(2).numpy(), obstacles)


def test_obstacle_contact_is_penalized_but_not_terminal_by_default(high_cfg, mid):
    env = HighPushEnv(high_cfg, mid, num_envs=2)
    _obstacle_on_robot_0_of_env_0(env)
    _, reward, terminated, _, _ = env.step(torch.zeros(2, 1, 2))
    assert env.exception.tolist() == [True, False]
    assert not terminated[0]
    assert reward[0, 0] < reward[1, 0]  # the -0.5 exception penalty (and obstacle proximity)


def test_an_exception_named_terminal_ends_its_episode_and_only_its_own(high_cfg, mid):
    high_cfg["level"]["terminal_exceptions"] = ["robot_hit_obstacle"]
    env = HighPushEnv(high_cfg, mid, num_envs=2)
    _obstacle_on_robot_0_of_env_0(env)
    _, _, terminated, truncated, info = env.step(torch.zeros(2, 1, 2))
    assert terminated.tolist() == [True, False] and not truncated.any()
    end = info["episode_end"]
    assert end["exception"].tolist() == [True, False] and not end["success"].any()


@pytest.mark.slow
def test_two_iteration_high_level_training_through_the_cli(cli, smoke_run, tmp_path):
    proc = cli("train", "level=high", f"mid={smoke_run}", "debug=smoke", f"train.run_root={tmp_path}")
    assert proc.returncode == 0, proc.stderr
    run_dir = Path(proc.stdout.strip().splitlines()[-1])
    assert (run_dir / "model_1.pt").is_file() and (run_dir / "policy.pt").is_file()
    evaluated = cli("eval", run_dir, "--episodes", "2")
    assert evaluated.returncode == 0, evaluated.stderr
    result = json.loads((run_dir / "eval.json").read_text())
    assert result["per_seed"][0]["planner_failure_rate"] == 0.0
    assert 0.0 <= result["success_rate"] <= 1.0 and result["timeout_s"] == 1.0
    # the planned paths run from the object's start area (x <= -4.5) to the goal area (x >= 5.5): 10 m at least
    assert result["path_length_m"] >= 10.0 and result["path_length_m"] == result["per_seed"][0]["path_length_m"]
    # the "path only" reference: the same run with every subgoal on the planned path, beside its own eval.json
    path_only = cli("eval", run_dir, "--episodes", "2", "level.follow_path=true")
    assert path_only.returncode == 0, path_only.stderr
    following = json.loads((run_dir / "eval_level.follow-path-true.json").read_text())
    assert following["per_seed"][0]["planner_failure_rate"] == 0.0 and following["episodes"] == 2
    assert json.loads((run_dir / "eval.json").read_text()) == result  # not overwritten


@pytest.mark.parametrize(
    ("mid_arg", "extra", "message"),
    [
        (None, [], "needs the frozen mid level: mid=RUN_DIR"),
        ("nowhere", [], "nowhere' does not exist; valid: a run dir or a model_<iteration>.pt"),
        ("SMOKE", ["task=tblock"], "trained on task cuboid with 2 agents, not tblock with 2"),
        ("SMOKE", ["task.num_agents=3"], "not cuboid with 3; valid: a mid run of task=cuboid task.num_agents=3"),
    ],
)
@pytest.mark.slow
def test_a_missing_or_mismatched_mid_level_is_bad_input(cli, smoke_run, tmp_path, mid_arg, extra, message):
    args = ["train", "level=high", "debug=smoke", f"train.run_root={tmp_path}", *extra]
    if mid_arg:
        args.append(f"mid={smoke_run if mid_arg == 'SMOKE' else mid_arg}")
    proc = cli(*args)
    assert proc.returncode == 2
    assert message in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert not any(tmp_path.rglob("config.yaml"))  # nothing written


@pytest.mark.slow
def test_a_high_level_run_is_not_a_mid_level(cli, smoke_run, tmp_path):
    first = cli("train", "level=high", f"mid={smoke_run}", "debug=smoke", f"train.run_root={tmp_path}")
    high_run = first.stdout.strip().splitlines()[-1]
    proc = cli("train", "level=high", f"mid={high_run}", "debug=smoke", f"train.run_root={tmp_path}")
    assert proc.returncode == 2
    assert "is a high-level run; valid: a mid-level run dir" in proc.stderr


def test_a_success_pays_the_held_task_terms_for_the_decisions_left(high_cfg, mid):
    env = HighPushEnv(high_cfg, mid, num_envs=2)  # 8 decisions per episode, gamma 0.99
    env.episode_step[:] = torch.tensor([3, 8])  # after the 3rd and the last decision
    factor = env._hold_factor(torch.tensor([True, True]))
    gamma = high_cfg["algo"]["algorithm"]["gamma"]
    assert factor[0].item() == pytest.approx(sum(gamma**k for k in range(6)), rel=1e-5)  # decisions 3..8
    assert factor[1].item() == pytest.approx(1.0)  # none left after this one
    assert env._hold_factor(torch.tensor([False, False])).tolist() == [1.0, 1.0]


def test_an_unknown_held_reward_term_is_bad_input(high_cfg, mid):
    from mapush.errors import BadInput

    high_cfg["level"]["hold_at_target"] = ["target_reached", "speed"]
    with pytest.raises(BadInput, match=r"'speed'.*valid: target_reached"):
        HighPushEnv(high_cfg, mid, num_envs=1)


def test_the_ml_baseline_env_pushes_straight_to_the_distant_target_among_obstacles(cfg_for):
    from mapush.envs.mid_long import LongMidPushEnv

    cfg = cfg_for("level=mid_long", "reward.terms.ocb=null")
    env = LongMidPushEnv(cfg, num_envs=3)
    assert torch.equal(env.subgoal_xy, env.target_xy)  # no high level: the final target is the subgoal
    assert (env.subgoal_distance >= 10.0).all()  # the areas are 10+ m apart along x
    assert env.max_episode_length == 8000  # 160 s at 50 Hz
    frame = env.scene_frame()
    placed = torch.isfinite(frame["obstacles"]).all(-1).all(-1) & (frame["obstacles"].abs() < 100).all(-1).all(-1)
    assert placed.sum() >= 3 * cfg["level"]["obstacles"]["count"] - 1
    obs, reward, *_ = env.step(torch.zeros(3, 2, 3))
    assert obs["policy"].shape[:2] == (3, 2) and reward.shape == (3, 2)
    assert "ocb" not in env.rewards.terms


def test_go_to_point_walks_straight_at_the_goal_within_the_limits():
    from mapush.lowlevel.goto import go_to_point

    limits = torch.tensor([0.5, 0.5, 0.5])
    robot_xy = torch.zeros(1, 4, 2)
    yaw = torch.tensor([[0.0, torch.pi / 2, 0.0, 0.0]])
    goal = torch.tensor([[[2.0, 0.0], [2.0, 0.0], [0.1, 0.05], [0.0, 3.0]]])
    cmd = go_to_point(robot_xy, yaw, goal, limits, gain=2.0, yaw_gain=2.0, arrive_m=0.2)[0]
    assert torch.allclose(cmd[0], torch.tensor([0.5, 0.0, 0.0]))  # ahead: full speed forward, no turn
    # facing +y with the goal along +x: the goal is to the robot's right, so vy < 0 and it turns clockwise
    assert torch.allclose(cmd[1], torch.tensor([0.0, -0.5, -0.5]), atol=1e-6)
    assert torch.allclose(cmd[2], torch.tensor([0.2, 0.1, 0.0]))  # near: 2 x the offset, inside arrive_m: no turn
    # far to the left: the speed is capped at 0.5 along y, and the turn at its limit
    assert torch.allclose(cmd[3], torch.tensor([0.0, 0.5, 0.5]), atol=1e-6)


def test_the_hl_baseline_gives_each_robot_its_own_goal_and_no_mid_level(cfg_for):
    from mapush.envs.nav_high import NavHighPushEnv, nav_high_obs_dim

    cfg = cfg_for("level=high_nav", "reward=high_nav_ft", "level.episode_length_s=4")
    env = NavHighPushEnv(cfg, num_envs=3)
    assert env.policy_agents == 2 and "ocb" in env.rewards.terms
    obs = env.observations()
    assert obs["policy"].shape == (3, 2, nav_high_obs_dim(cfg)) == obs["critic"].shape
    start = env.state.robot_xy.clone()
    # robot 0 walks toward the target (+x of the target frame), robot 1 away from it
    action = torch.tensor([[1.0, 0.0], [-1.0, 0.0]]).expand(3, 2, 2)
    obs, reward, *_ = env.step(action)
    heading = env.target_xy - env.state.object_xy
    heading = heading / torch.linalg.vector_norm(heading, dim=-1, keepdim=True)
    moved = ((env.state.robot_xy - start) * heading.unsqueeze(1)).sum(-1)  # (E, A) along the target direction
    assert (moved[:, 0] > 0.1).all() and (moved[:, 1] < -0.1).all()
    goal_offset = torch.linalg.vector_norm(env.robot_goal_xy - start, dim=-1)
    assert torch.allclose(goal_offset, torch.full((3, 2), cfg["level"]["robot_goal_range_m"]), atol=1e-4)
    assert reward.shape == (3, 2) and torch.isfinite(reward).all() and torch.isfinite(obs["policy"]).all()
    assert not (reward[:, 0] == reward[:, 1]).all()  # each robot's own heuristic terms (object approach, OCB)
