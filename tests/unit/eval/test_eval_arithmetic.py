"""Eval's arithmetic with hand-checked numbers: first episodes only, a failure counts as the timeout, S.R. and
C.T. as mean +- std over seeds (paper IV-B-1)."""

from __future__ import annotations

import pytest
import torch

from mapush.eval.rollout import first_episodes, summarize


class ScriptedVec:
    """A vec env whose episodes end as scripted: step -> {env: (success, exception, time_s[, exception_kind])}."""

    def __init__(self, script: dict[int, dict[int, tuple]], num_envs: int):
        self.script, self.num_envs, self.step_count, self.last_info = script, num_envs, 0, {}

    def get_observations(self):
        return torch.zeros(self.num_envs, 1)

    def step(self, actions):
        self.step_count += 1
        ends = self.script.get(self.step_count, {})
        rows = [(*ends[e], -1)[:4] if e in ends else (False, False, 0.0, -1) for e in range(self.num_envs)]
        success, exception, time_s, kind = zip(*rows, strict=True)
        end = {
            "done": torch.tensor([e in ends for e in range(self.num_envs)]),
            "success": torch.tensor(success),
            "exception": torch.tensor(exception),
            "time_s": torch.tensor(time_s),
            "exception_kind": torch.tensor(kind),  # -1: no exception ended the episode
        }
        self.last_info = {"episode_end": end}
        return self.get_observations(), None, None, None


class Env:
    num_envs, max_episode_length, dt = 3, 10, 0.02  # timeout 0.2 s
    exception_names = ("robot_collision", "robot_tilt")


def test_first_episodes_count_a_failure_as_the_timeout_and_ignore_later_episodes():
    script = {
        1: {0: (True, False, 0.04)},  # env 0 succeeds at 0.04 s
        2: {1: (False, True, 0.10, 1), 0: (False, True, 0.02, 0)},  # env 1 falls; env 0's 2nd episode: ignored
        3: {2: (False, False, 0.20)},  # env 2 times out
    }
    out = first_episodes(Env(), ScriptedVec(script, 3), lambda obs: obs, seed=7)
    assert out["seed"] == 7 and out["episodes"] == 3
    assert out["success_rate"] == pytest.approx(1 / 3)
    assert out["exception_rate"] == pytest.approx(1 / 3)
    assert out["exceptions"] == pytest.approx({"robot_collision": 0.0, "robot_tilt": 1 / 3})
    assert out["timeout_s"] == pytest.approx(0.2)
    assert out["completion_time_s"] == pytest.approx((0.04 + 0.2 + 0.2) / 3)  # failures count 0.2 s
    assert out["completion_time"] == pytest.approx((0.2 + 1.0 + 1.0) / 3)  # 0.04 / 0.2 = 0.2


def test_summary_is_the_mean_and_population_std_over_seeds():
    per_seed = [
        {"success_rate": 0.5, "completion_time": 0.6, "completion_time_s": 12.0, "timeout_s": 20.0,
         "exceptions": {"robot_tilt": 0.2, "object_tilt": 0.0}},
        {"success_rate": 0.7, "completion_time": 0.4, "completion_time_s": 8.0, "timeout_s": 20.0,
         "exceptions": {"robot_tilt": 0.1, "object_tilt": 0.1}},
    ]  # fmt: skip
    cfg = {"task": {"name": "cuboid", "num_agents": 2}, "level": {"name": "mid"}}
    out = summarize(cfg, "model_9.pt", 50, [0, 1], per_seed)
    assert out["success_rate"] == pytest.approx(0.6) and out["success_rate_std"] == pytest.approx(0.1)
    assert out["completion_time"] == pytest.approx(0.5) and out["completion_time_std"] == pytest.approx(0.1)
    assert out["completion_time_s"] == pytest.approx(10.0) and out["timeout_s"] == 20.0
    assert out["episodes"] == 50 and out["seeds"] == [0, 1] and out["checkpoint"] == "model_9.pt"
    assert out["exceptions"] == pytest.approx({"robot_tilt": 0.15, "object_tilt": 0.05})
