"""The config's ranges (`mapush.schema`) and eval's overrides in Hydra's grammar, with hand-checked numbers."""

from __future__ import annotations

import pytest
from omegaconf import OmegaConf

from mapush.config import apply_overrides, compose_config, group_options
from mapush.errors import BadInput
from mapush.schema import check_config, polygon_area


def test_polygon_area_by_hand():
    assert polygon_area([[0, 0], [2, 0], [2, 1], [0, 1]]) == pytest.approx(2.0)  # 2 x 1, counter-clockwise
    assert polygon_area([[0, 0], [0, 1], [2, 1], [2, 0]]) == pytest.approx(-2.0)  # the same, clockwise
    assert polygon_area([[0, 0], [1, 1], [2, 2]]) == 0.0  # collinear
    assert polygon_area([[0, 0], [1, 1]]) == 0.0
    assert polygon_area([["a", 0], [1, 1], [2, 0]]) == 0.0


def test_every_task_and_level_as_shipped_passes():
    for task in group_options("task"):
        for level in group_options("level"):
            cfg = compose_config([f"task={task}", f"level={level}"])  # composing runs check_config
            assert cfg.task.name == task and cfg.level.name == level


@pytest.mark.parametrize(
    ("key", "value"),
    [("sim.timestep", 0.0), ("sim.decimation", 0), ("sim.decimation", 2.5), ("algo.algorithm.lam", 1.01),
     ("algo.algorithm.learning_rate", float("nan")), ("num_envs", True), ("eval.episodes", "3"),
     ("sim.robot_contacts", "maybe"), ("sim.robot_contacts", 0)],
)  # fmt: skip
def test_out_of_range_or_ill_typed(key, value):
    cfg = compose_config()
    OmegaConf.update(cfg, key, value)
    with pytest.raises(BadInput, match=key.replace(".", r"\.")):
        check_config(cfg)


def test_a_clockwise_hull_is_refused_and_a_counter_clockwise_one_kept():
    cfg = compose_config(["task=ocb_cuboid"])
    cfg.task.object.hull = [[-0.6, -0.6], [0.6, -0.6], [0.6, 0.6], [-0.6, 0.6]]
    check_config(cfg)
    cfg.task.object.hull = cfg.task.object.hull[::-1]
    with pytest.raises(BadInput, match="counter-clockwise"):
        check_config(cfg)


def test_eval_overrides_in_hydras_grammar():
    cfg = compose_config()
    out = apply_overrides(cfg, ["sim.timestep=2e-3", "+extra.note=hi", "~log.video", "task=tblock", "eval.seeds=[3,4]"])
    assert out.sim.timestep == 0.002 and isinstance(out.sim.timestep, float)
    assert out.extra.note == "hi"
    assert "video" not in out.log
    assert out.task.name == "tblock"
    assert list(out.eval.seeds) == [3, 4]
    assert cfg.sim.timestep == 0.005  # the saved config is untouched
    with pytest.raises(BadInput, match=r"unknown config key 'sim\.timestepp'"):
        apply_overrides(cfg, ["sim.timestepp=1"])
    with pytest.raises(BadInput, match=r"bad override 'sim\.timestep'"):
        apply_overrides(cfg, ["sim.timestep"])
