"""Configs are data (`mapush.trust`): the names by which a config could reach code outside the trusted modules."""

from __future__ import annotations

import pytest

from mapush.config import compose_config
from mapush.errors import BadInput
from mapush.trust import check_trusted


@pytest.mark.parametrize(
    "path",
    [
        "pydoc:pipepager",  # an untrusted module
        "mapush.rewardsX:f",  # a prefix that is not the trusted package
        "rsl_rl.utils.utils:importlib.import_module",  # a trusted module lending a name it imported
        "rsl_rl:utils.utils.importlib.import_module",
        "rsl_rl.utils.utils.torch.load",  # the dotted form, which rsl-rl walks attribute by attribute
        "rsl_rl.utils.utils:__builtins__",
        "mapush.rewards.terms:torch",
        "${evil}",  # an interpolation that resolves elsewhere
    ],
)
def test_names_that_reach_outside_code_are_refused(path):
    with pytest.raises(BadInput, match="refused"):
        check_trusted("algo.algorithm.class_name", path)


@pytest.mark.parametrize(
    "path",
    [
        "PPO",
        "MLPModel",
        "rsl_rl.algorithms:PPO",
        "mapush.rewards.terms:subgoal_reached",
        "mapush.logging.metrics:McapLogWriter",
    ],
)
def test_mapush_s_and_rsl_rl_s_own_names_pass(path):
    assert check_trusted("k", path) is None


@pytest.mark.parametrize(
    "overrides",
    [
        ["algo.algorithm.class_name=${evil}", "+evil=antigravity:x"],
        ['+algo.algorithm.symmetry_cfg={data_augmentation_func: "antigravity:f"}'],  # not a class_name, still code
    ],
)
def test_a_config_cannot_name_code_through_interpolations_or_other_keys(overrides):
    with pytest.raises(BadInput, match="refused"):
        compose_config(["debug=smoke", *overrides])
