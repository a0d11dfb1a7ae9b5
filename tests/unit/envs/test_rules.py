"""`rules=original` and `rules=strict`: what ends an episode at each level, and the events counted whatever does."""

from __future__ import annotations

import pytest
import torch
from conftest import composed
from stand_ins import face_two_robots, stand_in_env

from mapush.config import compose_config, to_plain
from mapush.envs import terminations
from mapush.envs.events import EpisodeEvents
from mapush.envs.mid import MidPushEnv


def _level(*overrides: str) -> dict:
    return to_plain(compose_config(list(overrides)))["level"]


@pytest.mark.parametrize(("task", "distance"), [("cuboid", 0.25), ("cylinder", 0.25), ("tblock", 0.27)])
def test_the_original_mid_level_ends_a_push_on_its_own_exceptions(task, distance):
    """The original's task configs: bases within 0.25 m (0.27 m on the T-block), the object 0.35 m off its height;
    touching robots and a tilted object are mapush's rules and are dropped."""
    level = _level("level=mid", f"task={task}", "rules=original")
    exceptions = level["exceptions"]
    assert level["rules"] == "original"
    assert exceptions["robot_collision"] is None and exceptions["object_tilt"] is None  # dropped
    assert exceptions["robots_close"]["params"]["distance_m"] == distance
    assert exceptions["object_lifted"]["params"]["max_m"] == 0.35
    assert exceptions["robot_tilt"]["params"]["max_rad"] == 0.8
    strict = _level("level=mid", f"task={task}")
    assert strict["rules"] == "strict" and "robot_collision" in strict["exceptions"]
    assert "robots_close" not in strict["exceptions"]


@pytest.mark.parametrize("level", ["high", "high_nav"])
def test_the_original_hierarchy_ends_only_on_success_timeout_or_a_diverged_simulation(level):
    original, strict = _level(f"level={level}", "rules=original"), _level(f"level={level}")
    assert original["terminal_exceptions"] == ["diverged"] and original["fallen_robots"] == "still"
    assert {"robot_tilt", "object_tilt", "planner_failure"} <= set(strict["terminal_exceptions"])
    assert strict.get("fallen_robots", "act") == "act"  # the env's default: a fallen robot acts (and ends it)


@pytest.mark.parametrize("level", ["high", "high_nav", "mid", "mid_long"])
@pytest.mark.parametrize(("trained", "evaluated"), [("original", "strict"), ("strict", "original")])
def test_swapping_the_rules_of_a_saved_run_gives_the_level_as_composing_it_under_them_would(level, trained, evaluated):
    """`mapush eval RUN rules=...` (the ladder's rungs): the oracle is Hydra composing the level under the new
    rules. Merging the rule set's file alone kept the old set's endings (`rules=strict` is the level's own file)."""
    from mapush.config import apply_overrides

    run = compose_config([f"level={level}", "task=tblock", f"rules={trained}"])  # a run's config, as saved
    swapped = to_plain(apply_overrides(run, [f"rules={evaluated}"]))["level"]
    assert swapped == _level(f"level={level}", "task=tblock", f"rules={evaluated}")


def test_an_unknown_rule_set_is_refused_with_the_choices(cli):
    proc = cli("eval", "shipped:cuboid", "rules=lenient", "--episodes", "1")
    assert proc.returncode == 2
    assert "lenient" in proc.stderr and "original" in proc.stderr and "strict" in proc.stderr


def test_the_object_lifted_rule_reads_its_height_off_its_rest():
    sim = type("Sim", (), {"object_rest_z": torch.tensor([0.2, 0.2, 0.2])})()
    env = stand_in_env(object_z=torch.tensor([0.2, 0.56, -0.2]), sim=sim)
    assert terminations.object_height_change(env, 0.35).tolist() == [False, True, True]


def test_events_count_each_fallen_robot_once_and_each_contact_and_tilt_at_its_onset():
    """Two envs, two robots 0.3 m apart (touching at 0.28 m wide) then apart then touching again; robot 1 of env 0
    tilts past 0.8 rad and stays down; the object of env 1 tips twice. Env 1 is not live in the last step."""
    events = EpisodeEvents(num_envs=2, num_agents=2, thresholds=composed("debug=smoke")["eval"]["events"])
    size = [0.65, 0.28, 0.3]
    gaps = [0.285, 0.6, 0.285, 0.285]  # robot centres' y distance per step: touch, apart, touch, still touching
    robot_tilt = [[[0, 0], [0, 0]], [[0, 1.2], [0, 0]], [[0, 1.5], [0, 0]], [[0, 1.5], [0, 0.9]]]
    object_tilt = [[0, 0.9], [0, 0.1], [0, 0.9], [0, 0.1]]
    for step, gap in enumerate(gaps):
        xy = torch.tensor([[0.0, 0.0], [0.0, gap]]).expand(2, 2, 2)
        env = stand_in_env(
            robot_xy=xy, robot_yaw=torch.zeros(2, 2), robot_tilt=torch.tensor(robot_tilt[step]),
            object_tilt=torch.tensor(object_tilt[step]), num_agents=2, cfg={"lowlevel": {"size": size}},
        )  # fmt: skip
        events.update(env, live=torch.tensor([True, step < 3]))
    counts = events.counts()
    assert counts["falls"].tolist() == [1.0, 0.0]  # env 1's robot fell after its episode ended
    assert counts["robot_contacts"].tolist() == [2.0, 2.0]
    assert counts["object_tilts"].tolist() == [0.0, 2.0]
    events.reset(torch.tensor([True, False]))
    assert events.counts()["falls"].tolist() == [0.0, 0.0] and events.counts()["object_tilts"].tolist() == [0.0, 2.0]


@pytest.mark.slow
def test_under_the_original_rules_touching_trackers_push_on_and_the_contacts_are_counted():
    """Two trackers driven into each other, as `test_robot_contact.py` drives them: under `rules=strict` that ends
    the push; under `rules=original` it does not (their centres stay more than 0.25 m apart), and the evaluation
    env counts the contact."""
    cfg = to_plain(compose_config(["debug=smoke", "lowlevel=tracker", "num_envs=1", "level.episode_length_s=20",
                                   "rules=original"]))  # fmt: skip
    env = MidPushEnv(cfg, num_envs=1, evaluation=True)
    face_two_robots(env)
    forward = torch.tensor([[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]])
    for _ in range(int(4.0 / env.dt)):
        env.step(forward)
        assert not env.exception.any()
    assert env.events.counts()["robot_contacts"][0] >= 1


def test_the_events_count_at_the_strict_rules_own_thresholds():
    """The counts name what mapush's rules would end an episode on: a fall, touching robots, a tipped object."""
    cfg = composed("rules=strict", "level=mid")
    thresholds, exceptions = cfg["eval"]["events"], cfg["level"]["exceptions"]
    assert thresholds["fall_tilt_rad"] == exceptions["robot_tilt"]["params"]["max_rad"]
    assert thresholds["object_tilt_rad"] == exceptions["object_tilt"]["params"]["max_rad"]
    assert thresholds["contact_tolerance_m"] == exceptions["robot_collision"]["params"]["tolerance_m"]
