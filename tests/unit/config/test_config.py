"""Hydra composition: every option of every group composes, overrides apply, mistakes are BadInput."""

from __future__ import annotations

import pytest
from paths import REPO

from mapush.config import apply_overrides, compose_config, group_options, to_plain
from mapush.errors import BadInput


@pytest.mark.parametrize("group", ["task", "critic", "lowlevel", "level", "reward", "algo", "debug"])
def test_every_option_of_a_group_composes(group):
    for option in group_options(group):
        cfg = to_plain(compose_config([f"{group}={option}"]))
        assert isinstance(cfg, dict)
        if group in ("task", "lowlevel", "level"):
            assert cfg[group]["name"] == option


def test_group_options_are_the_yaml_files():
    assert group_options("critic") == ["global", "local"]
    assert group_options("lowlevel") == ["go1", "go1_strong", "tracker"]


def test_default_config_is_mid_cuboid_two_agents_mappo():
    cfg = to_plain(compose_config())
    assert (cfg["level"]["name"], cfg["task"]["name"], cfg["task"]["num_agents"]) == ("mid", "cuboid", 2)
    assert cfg["algo"]["obs_groups"] == {"actor": ["policy"], "critic": ["critic"]}


def test_local_critic_gives_the_critic_the_policy_observation():
    cfg = to_plain(compose_config(["critic=local"]))
    assert cfg["algo"]["obs_groups"] == {"actor": ["policy"], "critic": ["policy"]}


def test_smoke_debug_shrinks_the_run():
    cfg = to_plain(compose_config(["debug=smoke"]))
    assert (cfg["num_envs"], cfg["train"]["iterations"], cfg["level"]["episode_length_s"]) == (4, 2, 1.0)


def test_value_overrides_apply():
    cfg = to_plain(compose_config(["task=tblock", "task.num_agents=3", "seed=7"]))
    assert (cfg["task"]["name"], cfg["task"]["num_agents"], cfg["seed"]) == ("tblock", 3, 7)


def test_unknown_group_option_is_bad_input_naming_the_options():
    with pytest.raises(BadInput, match="unknown task 'sphere'; valid: cuboid, cylinder, ocb_cuboid, tblock"):
        compose_config(["task=sphere"])


def test_unknown_key_is_bad_input_naming_the_valid_keys():
    with pytest.raises(BadInput, match=r"iterationz.*valid.*iterations"):
        compose_config(["train.iterationz=3"])


def test_unknown_reward_term_is_bad_input_naming_the_valid_terms():
    with pytest.raises(BadInput, match=r"foo.*valid.*subgoal_reached"):
        compose_config(["reward.terms.foo.weight=1"])


def test_apply_overrides_changes_a_saved_config():
    cfg = apply_overrides(compose_config(["debug=smoke"]), ["task.num_agents=3", "eval.episodes=5"])
    assert (cfg.task.num_agents, cfg.eval.episodes) == (3, 5)


def test_apply_overrides_swaps_a_group():
    cfg = apply_overrides(compose_config(), ["task=cylinder"])
    assert cfg.task.name == "cylinder"


def test_apply_overrides_rejects_an_unknown_key_naming_the_valid_ones():
    with pytest.raises(BadInput, match=r"'train.iterationz'.*valid keys under 'train': iterations"):
        apply_overrides(compose_config(), ["train.iterationz=3"])


def test_apply_overrides_rejects_a_group_that_cannot_change():
    with pytest.raises(BadInput, match=r"'algo' cannot change.*valid: task, level, rules, lowlevel, reward"):
        apply_overrides(compose_config(), ["algo=mappo"])


def test_a_run_config_takes_current_defaults_only_for_level_settings_it_lacks(tmp_path):
    from omegaconf import OmegaConf

    from mapush.config import load_run_config

    saved = to_plain(compose_config(["level=locomotion", "level.commands.vx=[-0.3,0.3]"]))
    del saved["level"]["eval_commands"]["turn_fraction"]  # a run made before the setting existed
    OmegaConf.save(OmegaConf.create(saved), tmp_path / "config.yaml")
    cfg = load_run_config(tmp_path)
    assert cfg.level.eval_commands.turn_fraction == 0.0  # today's default
    assert list(cfg.level.commands.vx) == [-0.3, 0.3] and cfg.level.subject == "go1"  # as the run saved them


def test_a_run_config_takes_current_defaults_for_nested_level_settings_it_lacks(tmp_path):
    from omegaconf import OmegaConf

    from mapush.config import load_run_config

    saved = to_plain(compose_config(["level=high", "level.planner.margin_m=0.1"]))
    del saved["level"]["path"]["plan_in_training"]  # settings of the map and path nodes made after the run
    del saved["level"]["obstacles"]["train_clear_path"]
    OmegaConf.save(OmegaConf.create(saved), tmp_path / "config.yaml")
    cfg = load_run_config(tmp_path)
    assert cfg.level.obstacles.train_clear_path is True  # today's default
    assert cfg.level.path.plan_in_training is False  # not today's: the curved paths runs trained on before it existed
    assert cfg.level.planner.margin_m == 0.1 and cfg.level.path.points == 32  # as the run saved them


def _mid_weights(*overrides: str) -> dict[str, float]:
    terms = to_plain(compose_config(list(overrides)))["reward"]["terms"]
    return {name: terms[name]["weight"] for name in ("subgoal_progress", "agent_proximity", "ocb")}


def test_the_cylinder_weighs_its_mid_reward_as_the_original_checkpoints_did():
    # docs/fidelity.md: the stored cylinder checkpoints' target 50, collision -30, OCB 120, over 20000
    assert _mid_weights("task=cylinder") == pytest.approx(
        {"subgoal_progress": 50 / 20000, "agent_proximity": -30 / 20000, "ocb": 120 / 20000}
    )
    # the cuboid's are the paper's (App. B): 3.25e-3, -2.5e-3, 4e-3
    expected = {"subgoal_progress": 3.25e-3, "agent_proximity": -2.5e-3, "ocb": 4e-3}
    assert _mid_weights("task=cuboid") == pytest.approx(expected)
    assert _mid_weights("task=tblock") == pytest.approx(expected)


def test_a_command_line_weight_overrides_the_tasks_own():
    assert _mid_weights("task=cylinder", "reward.terms.ocb.weight=0.01")["ocb"] == pytest.approx(0.01)


@pytest.mark.parametrize(
    ("task", "effective"),
    # docs/fidelity.md: the original's object friction U[0.5, 0.6] (cuboid), U[0.6, 0.7] (T-block),
    # U[0.3, 0.4] (cylinder) on a 0.1 floor; PhysX's default combine mode averages a contact's two coefficients
    [("cuboid", [0.3, 0.35]), ("tblock", [0.35, 0.4]), ("cylinder", [0.2, 0.25])],
)
def test_the_object_slides_on_the_originals_friction_averaged_with_the_floor_as_physx_did(task, effective):
    assert to_plain(compose_config([f"task={task}"]))["task"]["object"]["friction"] == effective


def test_the_object_friction_follows_the_floor_and_yields_to_a_command_line_value():
    floor = to_plain(compose_config(["task=cylinder", "sim.floor_friction=0.3"]))["task"]["object"]["friction"]
    assert floor == [0.3, 0.35]
    typed = to_plain(compose_config(["task=cylinder", "task.object.friction=[0.5,0.6]"]))["task"]["object"]["friction"]
    assert typed == [0.5, 0.6]


def test_a_term_a_run_saved_stays_as_the_run_saved_it_not_merged_with_todays(tmp_path):
    """Runs made when robot_collision took the centre distance saved that term; today's default takes a footprint
    tolerance. A run loads with its own term, params and all, not with today's merged in."""
    from omegaconf import OmegaConf

    from mapush.config import load_run_config

    saved = OmegaConf.load(REPO / "mapush" / "policies" / "cuboid" / "mid" / "config.yaml")
    saved.level.exceptions.robot_collision = {
        "func": "mapush.envs.terminations:robot_collision",
        "params": {"distance_m": 0.25},
    }
    OmegaConf.save(saved, tmp_path / "config.yaml")
    today = compose_config(["level=mid"]).level.exceptions.robot_collision
    assert today.func != "mapush.envs.terminations:robot_collision"  # else this test checks nothing

    term = load_run_config(tmp_path).level.exceptions.robot_collision
    assert term.func == "mapush.envs.terminations:robot_collision"
    assert dict(term.params) == {"distance_m": 0.25}
