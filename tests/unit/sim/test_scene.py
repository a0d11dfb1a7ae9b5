"""The MjSpec scene: it compiles for every task and agent count, the object has geometric mass properties, and
`sim.robot_contacts=false` takes only the contacts between teammates away."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from stand_ins import touching_pairs

from mapush.config import group_options
from mapush.lowlevel.tracker import Tracker
from mapush.sim.scene import build_scene

TASKS = ["cuboid", "tblock", "cylinder", "ocb_cuboid"]


def compile_scene(cfg: dict) -> mujoco.MjModel:
    return build_scene(cfg["sim"], cfg["task"], Tracker(cfg["lowlevel"])).compile()


def object_inertia_tensor(model: mujoco.MjModel) -> np.ndarray:
    """The object's inertia about its centre of mass, in the body frame (MuJoCo stores principal axes + iquat)."""
    body = model.body("object")
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, body.iquat)
    rot = rot.reshape(3, 3)
    return rot @ np.diag(body.inertia) @ rot.T


def test_the_task_configs_are_the_four_paper_objects():
    assert group_options("task") == sorted(TASKS)


@pytest.mark.parametrize("num_agents", [1, 2, 3, 4])
@pytest.mark.parametrize("task", TASKS)
def test_scene_compiles_with_one_base_per_agent_and_the_object(cfg_for, task, num_agents):
    cfg = cfg_for(f"task={task}")
    cfg["task"]["num_agents"] = num_agents
    model = compile_scene(cfg)
    names = {model.body(i).name for i in range(model.nbody)}
    assert {f"robot{i}/base" for i in range(num_agents)} | {"object", "subgoal"} <= names
    assert f"robot{num_agents}/base" not in names
    assert model.nu == 3 * num_agents  # x, y, yaw actuators per robot


@pytest.mark.parametrize("task", TASKS)
def test_object_mass_is_the_sum_of_its_part_masses(cfg_for, task):
    cfg = cfg_for(f"task={task}")
    model = compile_scene(cfg)
    expected = sum(part["mass"] for part in cfg["task"]["object"]["parts"])
    assert model.body("object").mass[0] == pytest.approx(expected)


def test_cuboid_inertia_is_a_solid_box(cfg_for):
    # 1.2 x 1.2 x 0.5 m, 4 kg: Izz = 4 (1.2^2 + 1.2^2) / 12 = 0.96, Ixx = Iyy = 4 (1.2^2 + 0.5^2) / 12 = 0.5633
    inertia = object_inertia_tensor(compile_scene(cfg_for("task=cuboid")))
    assert np.diag(inertia) == pytest.approx([0.56333, 0.56333, 0.96], abs=1e-4)


def test_ocb_cuboid_inertia_is_a_solid_box(cfg_for):
    # 1.5 x 1.5 x 0.5 m, 6 kg: Izz = 6 (1.5^2 + 1.5^2) / 12 = 2.25
    inertia = object_inertia_tensor(compile_scene(cfg_for("task=ocb_cuboid")))
    assert inertia[2, 2] == pytest.approx(2.25)


def test_cylinder_inertia_is_a_solid_cylinder(cfg_for):
    # r = 1.5 m, h = 0.5 m, 10 kg: Izz = 0.5 * 10 * 1.5^2 = 11.25, Ixx = 10 (3 * 1.5^2 + 0.5^2) / 12 = 5.8333
    inertia = object_inertia_tensor(compile_scene(cfg_for("task=cylinder")))
    assert np.diag(inertia) == pytest.approx([5.8333, 5.8333, 11.25], abs=1e-4)


def test_tblock_centre_of_mass_and_inertia_follow_its_two_parts(cfg_for):
    # bar 1.0 x 0.5 (2 kg) at y = 0, stem 0.5 x 0.5 (1 kg) at y = 0.5: COM y = 0.5 / 3 = 0.1667.
    # Izz = 2 (1 + 0.25) / 12 + 2 * 0.1667^2 + 1 (0.25 + 0.25) / 12 + 1 * 0.3333^2 = 0.2639 + 0.1528 = 0.4167
    # Ixx = 2 * 0.5 / 12 + 2 * 0.1667^2 + 0.5 / 12 + 0.3333^2 = 0.2917;  Iyy = 2 * 1.25 / 12 + 0.5 / 12 = 0.25
    model = compile_scene(cfg_for("task=tblock"))
    assert model.body("object").ipos == pytest.approx([0.0, 0.16667, 0.0], abs=1e-4)
    assert np.diag(object_inertia_tensor(model)) == pytest.approx([0.29167, 0.25, 0.41667], abs=1e-4)


def test_object_rests_on_the_floor(cfg_for):
    # the body origin sits at half the tallest part's height: 0.5 m cuboid -> z = 0.25
    model = compile_scene(cfg_for("task=cuboid"))
    assert model.body("object").pos[2] == pytest.approx(0.25)


def touching_with_robots_at(cfg: dict, robot_xy: list[tuple[float, float]]) -> set[tuple[str, str]]:
    """Which bodies touch with the robots at `robot_xy` (the tracker's x and y slides) and the object where the task
    starts it."""
    model = compile_scene(cfg)
    data = mujoco.MjData(model)
    for i, (x, y) in enumerate(robot_xy):
        data.qpos[model.jnt_qposadr[model.joint(f"robot{i}/x").id]] = x
        data.qpos[model.jnt_qposadr[model.joint(f"robot{i}/y").id]] = y
    mujoco.mj_forward(model, data)
    return touching_pairs(model, data)


@pytest.mark.parametrize("robot_contacts", [True, False])
def test_sim_robot_contacts_false_lets_teammates_pass_through_each_other_only(cfg_for, robot_contacts):
    cfg = cfg_for(f"sim.robot_contacts={str(robot_contacts).lower()}")
    cfg["task"]["num_agents"] = 3
    sx, sy = cfg["task"]["object"]["start_xy"]
    half = cfg["task"]["object"]["parts"][0]["size"][0] / 2
    # robots 0 and 1 overlap far from the object; robot 2 stands half inside the object's -x face
    pairs = touching_with_robots_at(cfg, [(sx - 5.0, sy), (sx - 5.1, sy), (sx - half, sy)])
    assert (("robot0", "robot1") in pairs) is robot_contacts
    assert ("object", "robot2") in pairs
