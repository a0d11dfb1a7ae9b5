"""The Go1 model: compiles alone and attached into pushing scenes, matches its published facts, stands under PD."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest
import torch
from omegaconf import OmegaConf
from stand_ins import touching_pairs

from mapush.config import CONF_DIR
from mapush.errors import BadInput
from mapush.lowlevel import go1_constants as go1
from mapush.lowlevel.go1 import PROPRIO_DIM
from mapush.lowlevel.go1_model import go1_spec, standalone_spec
from mapush.sim.scene import build_scene, robot_prefixes

GAINS = {k: OmegaConf.load(CONF_DIR / "lowlevel" / "go1.yaml")[k] for k in ("kp", "kd")}
"""The servo gains the go1 backend and level=locomotion use."""


def test_the_model_compiles_alone_with_the_published_masses_ranges_and_torque_limits():
    model = standalone_spec(**GAINS).compile()
    assert model.nu == 12 and model.nq == 7 + 12
    assert sum(model.body_mass) == pytest.approx(12.03, abs=0.01)  # trunk 5.204 + 4 legs x 1.707 kg
    for name in go1.JOINT_NAMES:
        leg, joint = name.split("_")[:2]
        low, high = go1.JOINT_RANGE[joint]
        if joint == "hip" and go1.LEG_SIGNS[leg][1] < 0:
            low, high = -high, -low
        assert model.joint(name).range.tolist() == pytest.approx([low, high])
        actuator = model.actuator(name.replace("_joint", ""))
        assert actuator.forcerange.tolist() == pytest.approx([-go1.TORQUE_LIMIT[joint], go1.TORQUE_LIMIT[joint]])
    # the qpos layout follows JOINT_NAMES after the free joint
    assert [model.joint(name).qposadr[0] for name in go1.JOINT_NAMES] == list(range(7, 19))


def test_the_mjcf_it_writes_compiles_to_the_same_model():
    spec = go1_spec(**GAINS)
    again = mujoco.MjSpec.from_string(spec.to_xml()).compile()
    original = spec.compile()
    assert (again.nq, again.nu, again.nbody) == (original.nq, original.nu, original.nbody)
    assert sum(again.body_mass) == pytest.approx(sum(original.body_mass))


class Go1Robot:
    """A low level whose robot is the Go1: what `build_scene` attaches once per agent."""

    @staticmethod
    def robot_spec():
        return go1_spec(**GAINS)


@pytest.mark.parametrize("agents", [1, 2, 3, 4])
def test_the_model_attaches_by_prefix_into_a_pushing_scene(cfg_for, agents):
    composed_cfg = cfg_for()
    task = {**composed_cfg["task"], "num_agents": agents}
    model = build_scene(composed_cfg["sim"], task, Go1Robot(), obstacles=2).compile()
    assert model.nu == 12 * agents
    for prefix in robot_prefixes(agents):
        assert model.body(f"{prefix}{go1.ROOT_BODY}").mass[0] == pytest.approx(go1.TRUNK_INERTIAL[0])
        for name in go1.JOINT_NAMES:
            model.joint(f"{prefix}{name}")  # raises KeyError when missing


@pytest.mark.parametrize("robot_contacts", [True, False])
def test_go1s_that_overlap_touch_each_other_unless_robot_contacts_is_false(cfg_for, robot_contacts):
    composed_cfg = cfg_for(f"sim.robot_contacts={str(robot_contacts).lower()}")
    task = {**composed_cfg["task"], "num_agents": 2}
    model = build_scene(composed_cfg["sim"], task, Go1Robot()).compile()
    data = mujoco.MjData(model)
    # 0.1 m apart, the bodies interpenetrate; 1 cm below standing height, the feet press into the floor
    for prefix, y in zip(robot_prefixes(2), (0.0, 0.1), strict=True):
        address = model.jnt_qposadr[model.joint(prefix + go1.ROOT_JOINT).id]
        data.qpos[address : address + 3] = [-5.0, y, go1.standing_height() - 0.01]
        data.qpos[address + 3 : address + 7] = [1.0, 0.0, 0.0, 0.0]
        for name, angle in zip(go1.JOINT_NAMES, go1.default_joint_angles(), strict=True):
            data.qpos[model.jnt_qposadr[model.joint(prefix + name).id]] = angle
    mujoco.mj_forward(model, data)
    pairs = touching_pairs(model, data)
    assert (("robot0", "robot1") in pairs) is robot_contacts
    assert {("robot0", "world"), ("robot1", "world")} <= pairs  # each still stands on the floor


STIFF = {k: OmegaConf.load(CONF_DIR / "lowlevel" / "go1_strong.yaml")[k] for k in ("kp", "kd")}
"""The stiffer servo of `lowlevel=go1_strong`: it holds the standing pose with zero actions."""


def test_at_the_original_s_servo_gains_zero_actions_sag_but_stay_up():
    """kp 20, kd 0.5 cannot hold the pose against gravity without a policy's offsets (the reason go1_strong has 40):
    the trunk sinks and pitches, yet it does not fall."""
    model = standalone_spec(**GAINS).compile()
    data = mujoco.MjData(model)
    data.qpos[7:] = data.ctrl[:] = go1.default_joint_angles()
    for _ in range(round(2.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    x, y = data.qpos[4:6]
    tilt = math.acos(min(1 - 2 * (x * x + y * y), 1.0))
    assert 0.05 < tilt < 0.8 and data.qpos[2] > 0.15


def test_it_stands_still_in_the_default_pose_under_pd_for_2_s():
    model = standalone_spec(**STIFF).compile()
    data = mujoco.MjData(model)
    pose = np.array(go1.default_joint_angles())
    data.qpos[7:] = pose
    data.ctrl[:] = pose
    mujoco.mj_forward(model, data)
    start = data.qpos[:3].copy()
    for _ in range(round(2.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    x, y = data.qpos[4:6]  # quaternion (w, x, y, z)
    up = 1 - 2 * (x * x + y * y)  # z of the trunk's up axis
    assert math.acos(min(up, 1.0)) < 0.05  # rad of tilt
    assert np.linalg.norm(data.qpos[:2] - start[:2]) < 0.05  # m of drift
    assert abs(data.qpos[2] - go1.standing_height()) < 0.04  # m: the feet carry it at its standing height
    assert np.abs(data.qpos[7:] - pose).max() < 0.15  # rad: the servos hold the pose against gravity
    assert np.abs(data.qvel).max() < 0.05  # at rest


def test_the_locomotion_env_steps_with_the_documented_shapes_and_randomizes_each_env(cfg_for):
    import torch

    from mapush.envs.locomotion import LocomotionEnv

    cfg = cfg_for("level=locomotion")
    env = LocomotionEnv(cfg, num_envs=4)
    obs = env.observations()
    assert obs["policy"].shape == (4, 1, 45) and obs["critic"].shape == (4, 1, 48)
    spec = cfg["level"]["commands"]
    for k, key in enumerate(("vx", "vy", "yaw_rate")):
        assert ((env.commands[:, k] >= spec[key][0]) & (env.commands[:, k] <= spec[key][1])).all()
    floor = env.model.geom("floor").id
    assert len(set(env.sim.batch.expand("geom_friction")[:, floor, 0].round(6))) == 4  # one friction per env
    for _ in range(10):
        obs, reward, terminated, _, _ = env.step(torch.zeros(4, 1, 12))
        assert reward.shape == (4, 1) and torch.isfinite(reward).all() and torch.isfinite(obs["policy"]).all()
    assert not terminated.any()  # standing in the default pose does not fall
    # tipped on its back: a fall ends the episode as an exception
    env.sim.qpos[0, 3:7] = [0.0, 1.0, 0.0, 0.0]
    env.sim.batch.forward(np.array([0]))
    _, reward, terminated, _, info = env.step(torch.zeros(4, 1, 12))
    assert terminated[0] and info["episode_end"]["exception"][0] and reward[0, 0] < 0


def test_a_held_force_leans_on_the_trunk_for_its_duration_and_moves_it_that_way(cfg_for):
    import torch

    from mapush.envs.locomotion import LocomotionEnv

    cfg = cfg_for("level=locomotion", "level.events.push=null")  # no velocity pushes: only the force acts
    cfg["level"]["events"]["lean"]["params"] = {"force_n": 80.0, "interval_s": 0.4, "duration_s": 0.2}  # step 20, 10
    leaned = LocomotionEnv(cfg, num_envs=4)
    cfg["level"]["events"]["lean"]["params"]["force_n"] = 0.0
    upright = LocomotionEnv(cfg, num_envs=4)  # the same seed: the same starts, frictions and masses
    still = torch.zeros(4, 1, 12)  # the default pose under PD
    held = []
    for step in range(1, 31):
        leaned.step(still)
        upright.step(still)
        force = leaned.applied[:, leaned.trunk].copy()
        held.append(np.linalg.norm(force[:, :2], axis=1))
        assert (force[:, 2:] == 0).all()  # horizontal, no torque
        assert (upright.applied == 0).all()  # force_n 0: nothing applied
        if step == 20:
            direction = force[:, :2] / held[-1][:, None]
    held = np.array(held)  # (30 steps, 4 envs): drawn after episode step 20, cleared 10 steps later
    assert (held[:19] == 0).all() and (held[29] == 0).all()
    assert (held[19:29] == held[19]).all() and (held[19] > 0).all() and (held[19] <= 80.0).all()  # one size, held
    # until the force, both batches moved alike; then each leaned trunk went along its force (MuJoCo's dynamics)
    apart = leaned.sim.qpos[:, :2] - upright.sim.qpos[:, :2]
    assert ((apart * direction).sum(1) > 0).all()
    assert np.abs((apart * direction[:, ::-1] * [1, -1]).sum(1)).max() < np.abs((apart * direction).sum(1)).max()


@pytest.fixture(scope="module")
def low_run(tmp_path_factory) -> Path:
    """A 2-iteration `mapush train level=locomotion debug=smoke` run dir, made once through the CLI. Read-only."""
    from conftest import _run_cli

    root = tmp_path_factory.mktemp("low_runs")
    proc = _run_cli(["train", "level=locomotion", "debug=smoke", f"train.run_root={root}"], cwd=root)
    assert proc.returncode == 0, proc.stderr
    return Path(proc.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_a_2_iteration_low_level_training_and_its_eval_through_the_cli(cli, low_run, tmp_path):
    run_dir = tmp_path / "run"
    shutil.copytree(low_run, run_dir)
    assert (run_dir / "model_1.pt").is_file() and (run_dir / "policy.pt").is_file()
    evaluated = cli("eval", run_dir, "--episodes", "3")
    assert evaluated.returncode == 0, evaluated.stderr
    result = json.loads((run_dir / "eval.json").read_text())
    assert 0.0 <= result["fall_rate"] <= 1.0 and 0.0 <= result["velocity_error"] < 5.0
    assert 0.0 <= result["yaw_rate_error"] < 5.0
    assert "velocity error" in evaluated.stdout and "yaw rate error" in evaluated.stdout
    assert (run_dir / "episodes.mcap").stat().st_size > 0  # the Go1 walking, for Foxglove


@pytest.mark.slow
def test_shipping_a_run_writes_a_slim_run_dir_and_evaluates_the_shipped_files(cli, low_run, tmp_path):
    out = tmp_path / "go1"
    proc = cli("ship", low_run, out, "--episodes", "2", "--seeds", "0")
    assert proc.returncode == 0, proc.stderr
    result = json.loads((out / "eval.json").read_text())
    checkpoint = torch.load(out / "model_1.pt", weights_only=True)
    assert set(checkpoint) == {"actor_state_dict", "iter", "infos"}  # no critic, no optimizer
    assert result["checkpoint"] == "go1/model_1.pt"  # relative to where it ran: no machine path in the package
    assert 0.0 <= result["fall_rate"] <= 1.0
    assert json.loads((out / "meta.json").read_text())["shipped_from"]["run"] == low_run.name
    files = ["config.yaml", "overrides.yaml", "meta.json", "model_1.pt", "policy.pt", "policy.onnx", "eval.json"]
    files.append("sha256.json")  # the weights' digests, checked at load
    assert sorted(p.name for p in out.iterdir()) == sorted(files)
    obs = torch.randn(16, PROPRIO_DIM)
    shipped, source = torch.jit.load(out / "policy.pt"), torch.jit.load(low_run / "policy.pt")
    assert torch.equal(shipped(obs), source(obs))  # the same actor as the run's own export


@pytest.mark.slow
def test_compare_evaluates_a_tracker_run_as_trained_and_on_go1s(cli, smoke_run, low_run, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(smoke_run, run)
    policy = f"lowlevel.policy={low_run / 'policy.pt'}"
    out = tmp_path / "table"
    proc = cli("compare", run, "lowlevel=go1", policy, "--episodes", "2", "--seeds", "0", "--out", out)
    assert proc.returncode == 0, proc.stderr
    tracker = json.loads((run / "eval_as_trained.json").read_text())
    go1_files = [p for p in run.glob("eval_lowlevel-go1*.json")]
    assert len(go1_files) == 1
    go1 = json.loads(go1_files[0].read_text())
    assert tracker["episodes"] == go1["episodes"] == 2 and go1["checkpoint"] == tracker["checkpoint"]
    row = json.loads(out.with_suffix(".json").read_text())["rows"][0]
    assert row["drop"] == pytest.approx(tracker["success_rate"] - go1["success_rate"])
    assert row["with_overrides"]["success_rate"] == go1["success_rate"]
    assert (run / "eval.json").exists() == (smoke_run / "eval.json").exists()  # the run's own eval untouched
    assert "| run | cuboid | 2 |" in out.with_suffix(".md").read_text()


@pytest.mark.slow
def test_lowlevel_go1_with_a_missing_policy_is_one_clear_line(cli, tmp_path):
    proc = cli(
        "train",
        "lowlevel=go1",
        f"lowlevel.policy={tmp_path / 'nowhere.pt'}",
        "debug=smoke",
        f"train.run_root={tmp_path}",
    )
    assert proc.returncode == 2
    assert "nowhere.pt' does not exist" in proc.stderr and "mapush train level=locomotion" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not list(tmp_path.glob("mid/**/config.yaml"))


@pytest.mark.slow
def test_the_mid_level_drives_go1s_through_the_locomotion_policy(cfg_for, low_run):
    from mapush.envs.mid import MidPushEnv

    cfg = cfg_for("lowlevel=go1", f"lowlevel.policy={low_run / 'policy.pt'}")
    env = MidPushEnv(cfg, num_envs=3)
    assert env.sim.model.nu == 12 * env.num_agents
    layout_xy = env.state.robot_xy.clone()
    assert (env.state.robot_tilt < 0.05).all()  # placed standing upright
    trunk = env.sim.qpos[:, env.lowlevel.qpos_idx[:, 2]]
    assert np.allclose(trunk, go1.standing_height() + 0.01)
    before = env.sim.ctrl.copy()
    obs, reward, *_ = env.step(torch.zeros(3, env.num_agents, 3))
    assert not np.allclose(env.sim.ctrl, before)  # the locomotion policy wrote joint targets
    assert obs["policy"].shape[:2] == (3, env.num_agents) and torch.isfinite(reward).all()
    assert torch.linalg.vector_norm(env.state.robot_xy - layout_xy, dim=-1).max() < 0.2  # one 20 ms step
    # a robot tipped over is a fall: an exception of the mid level
    env.sim.qpos[0, env.lowlevel.qpos_idx[0, 3:7]] = [0.0, 1.0, 0.0, 0.0]
    env.sim.batch.forward(np.array([0]))
    *_, info = env.step(torch.zeros(3, env.num_agents, 3))
    assert info["episode_end"]["exception"][0]
    assert env.exception_names[int(info["episode_end"]["exception_kind"][0])] == "robot_tilt"


@pytest.mark.slow
def test_a_short_calibration_of_the_go1_writes_values_within_physical_bounds(cli, low_run, tmp_path):
    from mapush.calibration.run import default_config_path, physical_bounds

    package = default_config_path().read_bytes()
    before = OmegaConf.to_container(OmegaConf.load(default_config_path()))
    proc = cli("calibrate", f"lowlevel.policy={low_run / 'policy.pt'}", "--duration", "1", "--settle", "0.2",
               "--repeats", "1", "--out", tmp_path / "cal")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert default_config_path().read_bytes() == package  # calibrate never writes the package's config
    summary = json.loads((tmp_path / "cal" / "calibration.json").read_text())
    for key, value in summary["fitted"].items():
        if key in physical_bounds():
            low, high = physical_bounds()[key]
            assert low <= value <= high
    # a 2-iteration policy may not hold its commands, push or stand: what it cannot give is reported, not written
    untrusted = {w.split(":")[0] for w in summary["warnings"]}
    # and a tracker that falls more than 10 points apart from it in any test is not written at all
    assert untrusted <= {"lag", "yaw_lag", "max_force", "fall", "shove", "not written"}
    assert proc.stdout.count("warning: ") == len(summary["warnings"])
    written = tmp_path / "cal" / "lowlevel" / "tracker_calibrated.yaml"
    if "not written" in untrusted:
        assert summary["written"] == {} and not summary["consistency"]["passed"]
        assert summary["tracker_config"] is None and not written.exists() and "use it:" not in proc.stdout
        return
    after = OmegaConf.to_container(OmegaConf.load(written))
    changed = sorted(key for key in before if key != "name" and after[key] != before[key])
    assert changed == sorted(key for key, value in summary["written"].items() if value != before[key])
    assert "calibrated against go1" in written.read_text()
    assert "use it: mapush train lowlevel=tracker_calibrated" in proc.stdout
    assert set(summary["written"]) == {"lag", "yaw_lag", "max_force", "fall"} - untrusted


def test_a_turn_fraction_of_the_commands_turns_on_the_spot(cfg_for):
    from mapush.envs.locomotion import LocomotionEnv

    env = LocomotionEnv(cfg_for("level=locomotion", "level.commands.turn_fraction=0.5"), num_envs=4)
    commands = env._sample_commands(2000)
    on_the_spot = (commands[:, :2] == 0).all(-1)
    assert 0.45 < on_the_spot.float().mean() < 0.6  # half turn, a tenth of the rest stand still (0.5 + 0.05)
    assert commands[on_the_spot, 2].abs().mean() > 0.4  # they still turn, drawn from [-1, 1] rad/s


def test_without_a_load_or_teammate_fraction_the_scene_holds_the_go1_alone(cfg_for):
    from mapush.envs.locomotion import LocomotionEnv

    env = LocomotionEnv(cfg_for("level=locomotion"), num_envs=2)
    # runs trained before loads and teammates simulate what they trained on
    assert env.model.nq == 7 + 12 and env.model.nu == 12
    assert env.events["load"].bodies == [] and env.events["teammates"].mates is None


def test_teammates_stand_beside_the_robot_lean_into_it_and_park_where_unused(cfg_for):
    """Two teammate Go1s start left and right of the robot, `gap_m` from its side (measured in its frame with
    MuJoCo's rotation, the oracle), then, the robot told to stand, walk into it and touch it (MuJoCo's contact list);
    in episodes without them they stand parked, far away."""
    from mapush.envs.locomotion import LocomotionEnv
    from mapush.lowlevel.go1_training_scene import MATE_PARKED_XY

    cfg = cfg_for(
        "level=locomotion",
        "level.events.teammates.params.fraction=1.0",
        "level.events.teammates.params.lean_mps=[0.3,0.3]",
        "level.commands.zero_fraction=1.0",
        "level.events.push.params.velocity_mps=0.0",
    )
    env = LocomotionEnv(cfg, num_envs=8)
    teammates = env.events["teammates"]
    mates, width = cfg["level"]["events"]["teammates"]["params"], cfg["lowlevel"]["size"][1]
    assert env.model.nu == 12 * 3 and teammates.used.all()
    qpos = env.sim.qpos
    for e in range(8):
        for k, side in enumerate((1.0, -1.0)):
            world = np.array([*(teammates.mates.read(qpos, env.sim.qvel)["xy"][e, k] - qpos[e, :2]), 0.0])
            local = np.zeros(3)
            inverse = np.zeros(4)
            mujoco.mju_negQuat(inverse, qpos[e, 3:7])
            mujoco.mju_rotVecQuat(local, world, inverse)
            assert abs(local[0]) <= 0.3 + 1e-6  # beside it, not ahead or behind
            gap = side * local[1] - width  # its centre beyond a Go1's width: the gap between their sides
            assert mates["gap_m"][0] - 1e-6 <= gap <= mates["gap_m"][1] + 1e-6
    start = np.linalg.norm(teammates.mates.read(qpos, env.sim.qvel)["xy"] - qpos[:, None, :2], axis=-1)
    standing = torch.zeros(8, 1, 12)  # the default pose: the robot stands still
    for _ in range(75):  # 1.5 s
        env.step(standing)
    now = np.linalg.norm(teammates.mates.read(qpos, env.sim.qvel)["xy"] - qpos[:, None, :2], axis=-1)
    assert (now < start).mean() > 0.9
    data = mujoco.MjData(env.model)
    touched = 0
    for e in range(8):
        data.qpos[:], data.qvel[:] = qpos[e], env.sim.qvel[e]
        mujoco.mj_forward(env.model, data)
        pairs = touching_pairs(env.model, data)
        touched += any(("mate" in a) != ("mate" in b) and "world" not in (a, b) for a, b in pairs)
    assert touched >= 4

    unused = cfg_for("level=locomotion", "level.events.teammates.params.fraction=0.5")  # evaluation: none beside it
    parked = LocomotionEnv(unused, num_envs=64, evaluation=True).events["teammates"]
    xy = parked.mates.read(parked.env.sim.qpos, parked.env.sim.qvel)["xy"]
    assert not parked.used.any() and (np.linalg.norm(xy - np.array(MATE_PARKED_XY), axis=-1) < 2.0).all()


def test_a_load_stands_ahead_of_the_robot_along_its_command_and_drags_as_drawn(cfg_for):
    from mapush.envs.locomotion import LocomotionEnv
    from mapush.lowlevel.go1_training_scene import PARKED_XY

    cfg = cfg_for("level=locomotion", "level.events.load.params.fraction=1.0", "level.events.push=null")
    load = cfg["level"]["events"]["load"]["params"]
    env = LocomotionEnv(cfg, num_envs=16)
    loads = env.events["load"].bodies
    qpos, model = env.sim.qpos, env.model
    trunk_xy = qpos[:, :2]
    placed = np.zeros(16, dtype=int)
    reaches = (math.hypot(*load["box_size_m"][:2]) / 2, load["cylinder_size_m"][0])  # box corners, cylinder side

    def where(body) -> np.ndarray:
        """(E, 2) the load's planar position: its free joint's qpos."""
        return qpos[:, model.jnt_qposadr[body.jntadr[0]] :][:, :2]

    for body, reach, parked in zip(loads, reaches, PARKED_XY.values(), strict=True):
        xy = where(body)
        here = np.linalg.norm(xy - parked, axis=1) > 1.0
        placed += here
        for e in np.flatnonzero(here):
            ahead = np.zeros(3)  # the command's planar velocity, rotated into the world by MuJoCo (the oracle)
            mujoco.mju_rotVecQuat(ahead, np.array([*env.commands[e, :2].tolist(), 0.0]), qpos[e, 3:7])
            offset = xy[e] - trunk_xy[e]
            gap = np.linalg.norm(offset) - reach - go1.TRUNK_SIZE[0] / 2
            assert load["distance_m"][0] - 1e-6 <= gap <= load["distance_m"][1] + 1e-6
            if np.linalg.norm(ahead[:2]) >= 0.1:  # a command to stand or turn points nowhere: any direction
                assert np.dot(offset, ahead[:2]) / np.linalg.norm(offset) / np.linalg.norm(ahead[:2]) > 0.999
    assert (placed == 1).all()  # every episode has exactly one load, box or cylinder; the other is parked
    # its drag: held still by half of mu m g, slid by 1.5 times it (MuJoCo's contact friction, the larger of two)
    friction, mass = env.sim.batch.expand("geom_friction"), env.sim.batch.expand("body_mass")
    floor = model.geom("floor").id
    start, moved = {}, {}
    for share in (0.5, 1.5):
        env.reset(np.arange(16))
        for body in loads:
            start[body.id] = where(body).copy()
            drag = (
                mass[:, body.id] * 9.81 * np.maximum(friction[:, floor, 0], friction[:, model.body_geomadr[body.id], 0])
            )
            assert ((drag > load["resistance_n"][0] - 1e-6) & (drag < load["resistance_n"][1] + 1e-6)).all()
            away = start[body.id] - trunk_xy
            env.applied[:, body.id, :2] = share * drag[:, None] * away / np.linalg.norm(away, axis=1, keepdims=True)
        for _ in range(25):  # 0.5 s; the robot stands in its default pose, clear of the load
            env.sim.advance()
        moved[share] = np.concatenate([np.linalg.norm(where(b) - start[b.id], axis=1) for b in loads])
    assert moved[0.5].max() < 0.01 and moved[1.5].min() > 0.05


@pytest.mark.parametrize(
    ("command", "error", "bound"),
    [
        ((0.5, 0.0, 0.0), "velocity_error", 0.1),  # go1_strong walked it 0.15 m/s short (a strict xfail until
        # 2026-11-28); the original-like go1, never trained under a held load, holds it
        ((0.0, 0.0, 0.5), "yaw_rate_error", 0.1),
    ],
    ids=["forward", "turning"],
)
@pytest.mark.slow
def test_the_shipped_policy_holds_a_command_within_the_tracking_bound(cfg_for, command, error, bound):
    """5 s of one command on flat ground, no pushes: the shipped policy tracks it within 20 % of the command (0.5
    m/s forward: 0.1 m/s; 0.5 rad/s turning: 0.1 rad/s), measured after the first second."""
    from mapush.envs.locomotion import LocomotionEnv
    from mapush.lowlevel.go1 import load_locomotion_policy

    env = LocomotionEnv(cfg_for("level=locomotion"), num_envs=4, evaluation=True)  # evaluation: no pushes
    policy = load_locomotion_policy(None)  # lowlevel.policy: null, the shipped one
    env.commands[:] = torch.tensor(command)
    obs, errors = env.observations(), []
    with torch.inference_mode():
        for step in range(round(5.0 / env.dt)):
            obs, _, terminated, _, _ = env.step(policy(obs["policy"][:, 0]).unsqueeze(1))
            assert not terminated.any(), f"a fall at {step * env.dt:.2f} s"
            if step * env.dt >= 1.0:  # after a second to get going
                errors.append(getattr(env, error)())
    assert torch.stack(errors).mean() <= bound


@pytest.mark.slow
def test_a_run_started_from_another_runs_networks_fine_tunes_them(cli, low_run, smoke_run, tmp_path):
    import torch

    from mapush.config import load_run_config
    from mapush.rl.policy import read_checkpoint

    init = sorted(low_run.glob("model_*.pt"))[-1]
    # a learning rate too small to move the weights: the new run's first checkpoint holds the networks it started from
    proc = cli("train", "level=locomotion", "debug=smoke", "train.iterations=1", "algo.algorithm.learning_rate=1e-12",
               f"train.init_from={low_run}", f"train.run_root={tmp_path}")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    run = Path(proc.stdout.strip().splitlines()[-1])
    assert load_run_config(run).train.init_from == str(init.resolve())  # the exact checkpoint, recorded
    started, trained = read_checkpoint(init), read_checkpoint(run / "model_0.pt")
    assert trained["iter"] == 0  # its own iteration count, from 0
    for part in ("actor_state_dict", "critic_state_dict"):
        weights = [k for k in started[part] if k.startswith("mlp.")]
        assert weights and all(torch.allclose(started[part][k], trained[part][k], atol=1e-6) for k in weights)
    # bad input: one line, exit 2, no run dir
    mid_run = (smoke_run, "expects a 10-d observation but the config gives 45-d")  # the mid level's local observation
    mid_run = (smoke_run, "expects a 10-d observation but the config gives 45-d")  # the mid level's local observation
    for bad, named in ((tmp_path / "nope", "does not exist"), mid_run):
        proc = cli(
            "train", "level=locomotion", "debug=smoke", f"train.init_from={bad}", f"train.run_root={tmp_path}/bad"
        )
        assert proc.returncode == 2 and named in proc.stderr.strip().splitlines()[-1], proc.stderr
        assert not (tmp_path / "bad").exists()


def test_evaluation_replaces_the_event_params_that_eval_events_names(cfg_for):
    from mapush.envs.locomotion import LocomotionEnv

    cfg = cfg_for("level=locomotion", "level.events.lean.params.force_n=20.0", "level.eval_events.lean.force_n=40.0")
    training, evaluation = LocomotionEnv(cfg, num_envs=2), LocomotionEnv(cfg, num_envs=2, evaluation=True)
    assert training.events["lean"].force_n == 20.0 and evaluation.events["lean"].force_n == 40.0
    assert training.events["push"].velocity == 0.5 and evaluation.events["push"].velocity == 0.0  # low.yaml's
    assert training.events["lean"].duration_s == evaluation.events["lean"].duration_s == 2.0  # not replaced
    assert list(training.events) == ["push", "lean", "load", "teammates"]  # config order: the order of the draws


@pytest.mark.parametrize(
    ("override", "named"),
    [
        ("+level.eval_events.shove.force_n=1.0", "level.eval_events.shove names no event; valid: push, lean"),
        (
            "+level.eval_events.lean.size_n=1.0",
            "level.eval_events.lean (mapush.envs.locomotion_events:Lean) takes params",
        ),
        (
            "level.events.push.func=mapush.envs.locomotion_events:Shove",
            "valid in mapush.envs.locomotion_events: Event, Lean, Load",
        ),
        ("level.events.push.func=os:system", "level.events.push.func='os:system' names code outside the trusted"),
    ],
    ids=["unknown-event", "unknown-param", "unknown-class", "untrusted-code"],
)
def test_a_bad_event_is_refused_in_one_line_naming_it(cfg_for, override, named):
    from mapush.envs.locomotion_events import event_specs

    level = cfg_for("level=locomotion", override)["level"]
    for evaluation in (False, True):  # either mode's env refuses it before it builds anything
        with pytest.raises(BadInput) as refused:
            event_specs(level, evaluation)
        assert named in str(refused.value) and "\n" not in str(refused.value)


def test_a_bad_event_given_to_mapush_train_is_exit_2_and_makes_no_run_dir(cli, tmp_path):
    override = "+level.eval_events.shove.force_n=1.0"
    proc = cli("train", "level=locomotion", "debug=smoke", override, f"train.run_root={tmp_path / 'runs'}")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "level.eval_events.shove names no event; valid: push, lean" in proc.stderr
    assert not (tmp_path / "runs").exists()
