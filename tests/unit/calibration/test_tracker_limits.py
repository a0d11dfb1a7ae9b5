"""The tracker's two limits that stand for the legged Go1's: a cap on the norm of its planar push, and a fall when
it holds more than its Go1 could (mapush/lowlevel/tracker.py)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mapush.calibration.capacity import fall_overrides
from mapush.config import compose_config, to_plain
from mapush.envs.mid import MidPushEnv
from mapush.lowlevel import backend_of
from mapush.lowlevel.tracker import Tracker
from mapush.sim.push import PushSim

WALL_MASS = 1000.0
"""kg: an object this heavy (its floor drag about 5 kN) does not move under any robot: a wall."""
FALL = {"load_n": 20.0, "width_n": 1.0, "window_s": 1.0, "filter_s": 0.2}
"""A fall curve with its midpoint at 20 N and steep: a robot holding 30 N falls within seconds, one holding 10 N
(P = 5e-5 a second) almost never."""


def _cfg(*overrides: str) -> dict:
    return to_plain(compose_config(["debug=smoke", "lowlevel=tracker", "task=cuboid", "num_envs=1", *overrides]))


def _wall_layout(n: int, cfg: dict) -> dict[str, torch.Tensor]:
    """Each robot just behind the cuboid (a wall, once heavy), facing it along +x."""
    gap = 0.6 + cfg["lowlevel"]["size"][0] / 2 + 0.02  # the cuboid's half size, half the robot, 2 cm
    return {
        "object_xy": torch.zeros(n, 2),
        "object_yaw": torch.zeros(n),
        "robot_xy": torch.tensor([-gap, 0.0]).expand(n, 1, 2).clone(),
        "robot_yaw": torch.zeros(n, 1),
        "subgoal_xy": torch.tensor([5.0, 0.0]).expand(n, 2).clone(),
        "friction": torch.full((n,), 0.5),
    }


def _make_wall(sim: PushSim) -> None:
    sim.set_object_mass(np.arange(sim.num_envs), np.full(sim.num_envs, WALL_MASS))


def _planar_forces(force_cap: str, command: list[float], cap: float = 30.0) -> np.ndarray:
    """The slides' force norms (N) at every policy step of a robot driven at `command` into a wall for 2 s."""
    cfg = _cfg("task.num_agents=1", f"lowlevel.force_cap={force_cap}", f"lowlevel.max_force={cap}")
    backend = backend_of(cfg["lowlevel"])(cfg["lowlevel"])
    sim = PushSim(cfg["sim"], cfg["task"], backend, 1)
    _make_wall(sim)
    sim.reset(np.arange(1), _wall_layout(1, cfg))
    force = sim.batch.bind("actuator_force")
    slides = backend.ctrl_idx[0, :2]
    norms = []
    for _ in range(round(2.0 / sim.dt)):
        sim.step(torch.tensor([[command]]))
        norms.append(float(np.linalg.norm(force[0, slides])))
    return np.array(norms)


@pytest.mark.parametrize("command", [[0.5, 0.0, 0.0], [0.5, 0.5, 0.0], [0.3, -0.5, 0.4]])
def test_planar_force_never_exceeds_the_cap(command):
    norms = _planar_forces("planar", command)
    assert norms.max() <= 30.0 + 1e-6
    assert norms.max() > 0.95 * 30.0  # pressed into the wall, the push reaches the cap


def test_capping_each_axis_lets_a_diagonal_push_exceed_the_cap():
    """What `planar` fixes: the earlier per-axis cap lets a diagonal push reach sqrt(2) x its value."""
    assert _planar_forces("axes", [0.5, 0.5, 0.0]).max() > 1.3 * 30.0


def _steps_to_fall(max_force: float, seconds: float = 10.0) -> tuple[int | None, str | None]:
    """A tracker with `FALL` pushing a wall at full speed: the step its episode ended at and the exception."""
    cfg = _cfg(
        "task.num_agents=1",
        "lowlevel.force_cap=planar",
        f"lowlevel.max_force={max_force}",
        *fall_overrides(FALL),  # the whole model, no shove curve of the config merged in
        "level.episode_length_s=30",
    )
    env = MidPushEnv(cfg, num_envs=1)
    _make_wall(env.sim)
    env.sim.reset(np.arange(1), _wall_layout(1, cfg))
    env._read_state()
    for step in range(round(seconds / env.dt)):
        env.step(torch.tensor([[[1.0, 0.0, 0.0]]]))
        if env.exception.any():
            return step, env.exception_names[int(env.exception_kind[0])]
    return None, None


def test_a_tracker_holding_more_than_its_go1_could_falls():
    step, exception = _steps_to_fall(max_force=40.0)  # it pushes 12 kg / lag x 0.5 m/s, about 34 N
    assert step is not None
    assert exception == "robot_tilt"  # the exception a Go1's fall ends an episode with


def test_a_tracker_holding_less_does_not_fall():
    assert _steps_to_fall(max_force=10.0) == (None, None)


def test_a_bad_fall_model_is_one_line():
    from mapush.errors import BadInput

    with pytest.raises(BadInput, match=r"lowlevel\.fall"):
        Tracker.check({"fall": {"load_n": 20.0}})
    with pytest.raises(BadInput, match="force_cap"):
        Tracker.check({"force_cap": "norm"})


def test_a_shove_curve_needs_both_keys_and_a_positive_shape():
    from mapush.errors import BadInput

    base = {"load_n": 67.1, "width_n": 0.47, "window_s": 4.0, "filter_s": 0.2}
    Tracker.check({"fall": {**base, "shove_mps": 0.17, "shove_shape": 6.0}})
    for wrong in ({"shove_mps": 0.17}, {"shove_mps": 0.17, "shove_shape": 0.0}, {"shove_mps": -0.1, "shove_shape": 2}):
        with pytest.raises(BadInput, match=r"lowlevel\.fall"):
            Tracker.check({"fall": {**base, **wrong}})
