"""The contact probe (`mapush probe contacts`): which parts of a robot push the object, read at every physics step."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mapush.calibration import contacts
from mapush.config import compose_config, to_plain
from mapush.lowlevel import backend_of
from mapush.sim.push import PushSim


def test_part_names_drop_the_robot_and_the_leg():
    assert contacts.part_name("robot0/FR_calf") == "calf"
    assert contacts.part_name("robot2/trunk") == "trunk"
    assert contacts.part_name("robot1/base") == "base"
    assert contacts.part_name("object") == "object"


def test_stepping_with_a_substep_hook_steps_alike_and_calls_it_every_physics_step():
    cfg = to_plain(compose_config(["task=cuboid", "sim.nthread=1"]))
    sims = [PushSim(cfg["sim"], cfg["task"], backend_of(cfg["lowlevel"])(cfg["lowlevel"]), 2) for _ in range(2)]
    calls = []
    commands = np.tile([0.4, 0.1, 0.2], (2, cfg["task"]["num_agents"], 1))
    for _ in range(5):
        sims[0].step(torch.from_numpy(commands).float())
        sims[1].step(torch.from_numpy(commands).float(), substep=lambda: calls.append(1))
    assert len(calls) == 5 * cfg["sim"]["decimation"]
    np.testing.assert_array_equal(sims[0].qpos, sims[1].qpos)


@pytest.mark.slow
def test_a_tracker_pushing_the_cuboid_balances_the_floor_drag_with_its_own_base():
    (push,) = contacts.contact_sweep(["lowlevel=tracker", "sim.nthread=1"], [0.5], repeats=2, seed=0)
    assert push["parts"] == [contacts.FLOOR, "base"]
    mean = push["force"].mean((0, 1))
    # Newton: the object slides at a near-steady speed, so the push it gets equals the floor's drag on it
    assert mean[1] > 5.0 and mean[1] == pytest.approx(-mean[0], rel=0.05)
    drag = 4.0 * 9.81 * np.mean(to_plain(compose_config(["task=cuboid"]))["task"]["object"]["friction"])
    assert -mean[0] == pytest.approx(drag, rel=0.2)  # the cuboid's mass and its sliding friction
    assert np.isclose(contacts.jolt_shares(push)[1], 1.0)  # a robot of one part drives every jolt
