"""The RewardManager: config terms (func, weight, params) weighed and summed; config mistakes are BadInput."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import torch
from stand_ins import stand_in_env

from mapush.config_terms import resolve_term
from mapush.errors import BadInput
from mapush.rewards.manager import RewardManager

REACHED = {"func": "mapush.rewards.terms:subgoal_reached", "weight": 10.0}
EXCEPTION = {"func": "mapush.rewards.terms:exception", "weight": -5.0}
PROGRESS = {"func": "mapush.rewards.terms:subgoal_progress", "weight": 0.5, "params": {"alpha": 200.0}}


def stand_in() -> SimpleNamespace:
    """Env 0 succeeded (d 2.0 -> 1.9), env 1 failed (d 1.0 -> 1.1); 2 agents each."""
    return stand_in_env(
        num_envs=2,
        num_agents=2,
        policy_agents=2,
        success=torch.tensor([True, False]),
        exception=torch.tensor([False, True]),
        prev_subgoal_distance=torch.tensor([2.0, 1.0]),
        subgoal_distance=torch.tensor([1.9, 1.1]),
    )


def test_weights_multiply_each_term_and_the_terms_add_up():
    # env 0: 10 * 1 + 0.5 * 18.1 = 19.05; env 1: -5 * 1 + 0.5 * (-21.1) = -15.55
    total, parts = RewardManager({"reached": REACHED, "exception": EXCEPTION, "progress": PROGRESS}).compute(stand_in())
    assert parts["reached"].tolist() == [[10.0, 10.0], [0.0, 0.0]]
    assert parts["exception"].tolist() == [[0.0, 0.0], [-5.0, -5.0]]
    assert total.numpy() == pytest.approx(np.array([[19.05, 19.05], [-15.55, -15.55]]), abs=1e-4)


def test_positive_only_clips_the_shaping_terms_at_zero_before_adding_the_terminal_ones():
    # shaping: env 0 0.5 * 18.1 = 9.05, env 1 0.5 * (-21.1) -> clipped to 0; the terminal exception then adds -5
    terms = {"progress": PROGRESS, "exception": {**EXCEPTION, "terminal": True}}
    total, parts = RewardManager(terms, positive_only=True).compute(stand_in())
    assert total.numpy() == pytest.approx(np.array([[9.05, 9.05], [-5.0, -5.0]]), abs=1e-4)
    assert parts["progress"][1].tolist() == pytest.approx([-10.55, -10.55])  # the parts stay unclipped for the logs


def test_a_null_term_is_dropped():
    manager = RewardManager({"reached": REACHED, "exception": None})
    assert list(manager.terms) == ["reached"]


def test_a_zero_weight_term_is_dropped():
    manager = RewardManager({"reached": REACHED, "exception": {**EXCEPTION, "weight": 0.0}})
    assert list(manager.terms) == ["reached"]


def test_no_terms_give_zero_reward():
    total, parts = RewardManager({"exception": None}).compute(stand_in())
    assert parts == {}
    assert total.tolist() == [[0.0, 0.0], [0.0, 0.0]]


def test_missing_params_raise_bad_input_naming_the_wanted_ones():
    with pytest.raises(BadInput, match=r"takes params \['alpha'\]"):
        RewardManager({"progress": {**PROGRESS, "params": None}})


def test_a_param_with_a_default_may_be_left_out():
    # high-level runs saved before path_following took `point` still load, with the behaviour they trained with
    manager = RewardManager({"follow": {"func": "mapush.rewards.terms:path_following", "weight": 0.5}})
    assert manager.terms["follow"][2] == {}


def test_extra_params_raise_bad_input():
    with pytest.raises(BadInput, match="beta"):
        RewardManager({"progress": {**PROGRESS, "params": {"alpha": 200.0, "beta": 1.0}}})


def test_params_for_a_function_without_any_raise_bad_input():
    with pytest.raises(BadInput, match="reached"):
        RewardManager({"reached": {**REACHED, "params": {"alpha": 1.0}}})


def test_unknown_function_raises_bad_input_naming_the_valid_functions():
    with pytest.raises(BadInput) as err:
        RewardManager({"x": {"func": "mapush.rewards.terms:nope", "weight": 1.0}})
    message = str(err.value)
    assert "'mapush.rewards.terms:nope'" in message
    for name in ("subgoal_reached", "subgoal_progress", "occlusion_based", "object_moving"):
        assert name in message
    assert "_shared" not in message  # private helpers are not offered


def test_unknown_module_raises_bad_input():
    with pytest.raises(BadInput, match=r"mapush\.nowhere"):
        resolve_term("mapush.nowhere:f")


def test_every_configured_mid_term_resolves(cfg_for):
    manager = RewardManager(cfg_for()["reward"]["terms"])
    paper = {"subgoal_reached", "subgoal_progress", "exception", "agent_proximity", "object_approach", "object_moving",
             "ocb"}  # fmt: skip
    assert set(manager.terms) == paper | {"robot_jam"}  # on the cuboid
    for task in ("tblock", "cylinder", "ocb_cuboid"):  # these weigh robot_jam 0: the manager drops it
        assert set(RewardManager(cfg_for(f"task={task}")["reward"]["terms"]).terms) == paper, task


@pytest.mark.parametrize("value", ["fast", True, [200.0]])
def test_a_param_of_the_wrong_type_raises_bad_input_naming_the_key_and_the_type(value):
    with pytest.raises(BadInput, match=r"reward\.terms\.progress\.params\.alpha=.* is not of type float"):
        RewardManager({"progress": {**PROGRESS, "params": {"alpha": value}}})


def test_an_int_is_a_float_param():
    manager = RewardManager({"progress": {**PROGRESS, "params": {"alpha": 200}}})
    assert manager.terms["progress"][2] == {"alpha": 200}
