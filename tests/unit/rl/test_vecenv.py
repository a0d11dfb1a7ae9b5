"""The env x agent row layout that rsl-rl sees: row = env * A + agent."""

from __future__ import annotations

import torch

from mapush.envs.base import EpisodeOutcomes
from mapush.rl.vecenv import AgentRowsVecEnv, env_flags_to_rows, from_rows, to_rows


def test_to_rows_puts_agent_a_of_env_e_in_row_e_times_a_plus_a():
    # x[e, a] = 10 e + a, 3 envs x 2 agents -> rows 0, 1, 10, 11, 20, 21
    x = 10 * torch.arange(3).unsqueeze(1) + torch.arange(2)
    assert to_rows(x).tolist() == [0, 1, 10, 11, 20, 21]


def test_to_rows_keeps_trailing_dims():
    assert to_rows(torch.zeros(3, 2, 5)).shape == (6, 5)


def test_from_rows_inverts_to_rows():
    x = torch.randn(4, 3, 7, generator=torch.Generator().manual_seed(0))
    assert torch.equal(from_rows(to_rows(x), 3), x)


def test_from_rows_reads_row_r_as_env_r_div_a_agent_r_mod_a():
    rows = torch.arange(6)
    assert from_rows(rows, 3).tolist() == [[0, 1, 2], [3, 4, 5]]


def test_env_flags_repeat_for_every_agent_of_the_env():
    assert env_flags_to_rows(torch.tensor([True, False]), 3).tolist() == [True, True, True, False, False, False]


class FakeEnv:
    """2 envs x 3 agents whose step returns reward 10 e + a, env 0 terminated, env 1 truncated."""

    num_envs, num_agents, policy_agents, max_episode_length = 2, 3, 3, 50
    action_scale = torch.tensor([0.5, 0.5, 0.5])  # (vx, vy, yaw rate): 3 actions per agent
    num_actions = 3

    def __init__(self):
        self.cfg: dict = {}
        self.episode_step = torch.tensor([4, 9])
        self.actions = None
        self.outcomes = EpisodeOutcomes()

    def observations(self):
        return {"policy": torch.arange(6.0).reshape(2, 3, 1), "critic": torch.zeros(2, 3, 4)}

    def step(self, actions):
        self.actions = actions
        reward = 10 * torch.arange(2.0).unsqueeze(1) + torch.arange(3.0)
        info = {"episode_end": {}, "log": {"Metrics/success_rate": torch.tensor(0.5)}}
        return self.observations(), reward, torch.tensor([True, False]), torch.tensor([False, True]), info


def test_vecenv_counts_rows_not_envs():
    vec = AgentRowsVecEnv(FakeEnv())
    assert vec.num_envs == 6
    assert vec.get_observations()["policy"].flatten().tolist() == [0, 1, 2, 3, 4, 5]


def test_vecenv_step_maps_rewards_dones_and_time_outs_to_rows():
    vec = AgentRowsVecEnv(FakeEnv())
    _, rewards, dones, extras = vec.step(torch.zeros(6, 3))
    assert rewards.tolist() == [0, 1, 2, 10, 11, 12]
    assert dones.tolist() == [True] * 6
    assert extras["time_outs"].tolist() == [False, False, False, True, True, True]
    assert extras["log"]["Metrics/success_rate"].item() == 0.5


def test_vecenv_step_hands_row_actions_back_as_env_agent():
    env = FakeEnv()
    vec = AgentRowsVecEnv(env)
    actions = torch.arange(18.0).reshape(6, 3)
    vec.step(actions)
    assert env.actions.shape == (2, 3, 3)
    assert env.actions[1, 2].tolist() == [15.0, 16.0, 17.0]  # row 5 = env 1, agent 2


def test_episode_length_buf_is_per_row_and_writes_back_per_env():
    env = FakeEnv()
    vec = AgentRowsVecEnv(env)
    assert vec.episode_length_buf.tolist() == [4, 4, 4, 9, 9, 9]
    vec.episode_length_buf = torch.tensor([7, 7, 7, 2, 2, 2])
    assert env.episode_step.tolist() == [7, 2]


def test_vecenv_over_the_real_env_returns_one_reward_and_done_per_row(make_env):
    vec = AgentRowsVecEnv(make_env("debug=smoke", num_envs=3))
    obs, rewards, dones, extras = vec.step(torch.zeros(6, 3))
    assert obs["policy"].shape == (6, 10)
    assert obs["critic"].shape == (6, 26)
    assert rewards.shape == dones.shape == extras["time_outs"].shape == (6,)


def test_vecenv_rewards_are_the_env_rewards_in_row_order(make_env):
    # the same seed and actions through the env directly and through the vecenv
    direct, wrapped = make_env("debug=smoke", num_envs=3), AgentRowsVecEnv(make_env("debug=smoke", num_envs=3))
    actions = torch.randn(3, 2, 3, generator=torch.Generator().manual_seed(0))
    _, reward, *_ = direct.step(actions)
    _, rows, _, _ = wrapped.step(to_rows(actions))
    assert torch.equal(rows, to_rows(reward))


def test_an_episode_begun_part_way_stays_out_of_the_logged_success_and_the_next_one_counts():
    outcomes = EpisodeOutcomes()
    outcomes.part_way = torch.tensor([True, False])
    done, success = torch.tensor([True, True]), torch.tensor([True, False])
    end = {"done": done, "success": success, "exception": ~success, "time_s": torch.ones(2)}
    first = outcomes.info(end, {})["log"]
    assert first["Metrics/success_rate"] == 0.0 and first["Metrics/recent_success_rate"] == 0.0  # env 1's alone
    second = outcomes.info(end, {})["log"]  # env 0's next episode began at a reset: it counts
    assert second["Metrics/success_rate"] == 0.5
    assert outcomes.part_way.tolist() == [False, False]


def test_a_resumes_spread_marks_the_envs_it_set_part_way_and_a_fresh_runs_does_not():
    vec = AgentRowsVecEnv(FakeEnv())
    vec.episode_length_buf = torch.tensor([0, 0, 0, 7, 7, 7])
    assert vec.env.outcomes.part_way is None
    vec.count_whole_only = True
    vec.episode_length_buf = torch.tensor([0, 0, 0, 7, 7, 7])
    assert vec.env.outcomes.part_way.tolist() == [False, True]
