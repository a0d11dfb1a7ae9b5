"""`algo.actor.distribution_cfg.std_range` bounds the mid level's exploration noise (a probe's setting, 2026-12-02):
beyond the raw output where a command saturates (1 / level.action_gain) noise changes nothing the env does, and
the entropy bonus alone grows it there."""

from __future__ import annotations

from mapush.rl.runner import MapushRunner, learn, train_cfg_for
from mapush.rl.vecenv import AgentRowsVecEnv

BOUND = "+algo.actor.distribution_cfg.std_range=[1.0e-6,1.0]"


def trained_std(make_env, tmp_path, *overrides: str) -> float:
    """The actor's largest action std after 3 smoke iterations whose loss is almost all entropy bonus."""
    entropy_only = ("algo.algorithm.entropy_coef=100.0", "algo.algorithm.learning_rate=0.1")
    env = make_env("debug=smoke", *entropy_only, "algo.algorithm.schedule=fixed", *overrides)
    tmp_path.mkdir()
    runner = MapushRunner(AgentRowsVecEnv(env), train_cfg_for(env.cfg, env.num_agents, 3), log_dir=str(tmp_path))
    learn(runner, 3, tmp_path / "train.log")
    runner.alg.actor(runner.env.get_observations(), stochastic_output=True)  # sets the distribution's std
    return float(runner.alg.actor.distribution.std.detach().max())


def test_an_entropy_bonus_cannot_push_the_noise_past_a_std_range(make_env, tmp_path):
    assert trained_std(make_env, tmp_path / "bounded", BOUND) <= 1.0 + 1e-6
    # the same training without a range (the default, rsl-rl's own) grows it past 1: the check above can fail
    assert trained_std(make_env, tmp_path / "free") > 1.0
