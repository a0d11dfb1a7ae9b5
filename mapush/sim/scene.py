"""Pushing scenes composed with MjSpec: walled arena, N robots attached by prefix, the object, a subgoal marker."""

from __future__ import annotations

import itertools

import mujoco

from mapush.planning.geometry import PARKED

OBJECT_BODY = "object"
OBJECT_JOINT = "object_root"
SUBGOAL_BODY = "subgoal"
OBSTACLE_BODY = "obstacle{}"
ROBOT_PREFIX = "robot{}/"

# Contact bits: the floor is bit 1, robots bit 2; the object and the walls touch both.
FLOOR_BITS, OBJECT_BITS = 1, 3


def robot_prefixes(num_agents: int) -> list[str]:
    """Name prefixes of the robots: `robot0/`, `robot1/`, ..."""
    return [ROBOT_PREFIX.format(i) for i in range(num_agents)]


def build_scene(
    sim_cfg: dict, task_cfg: dict, lowlevel, obstacles: int = 0, obstacle_size=(1.0, 1.0, 1.0)
) -> mujoco.MjSpec:
    """The pushing scene of one env, as an MjSpec (compile it, or edit it first).

    Args:
        sim_cfg: the `sim` config block (timestep, arena).
        task_cfg: the task config (object parts, agent count).
        lowlevel: a low-level backend; its `robot_spec()` is attached once per agent.
        obstacles: number of obstacle blocks (the high level), mocap bodies placed per env at reset.
        obstacle_size: their footprint x, y and height, m.
    """
    spec = mujoco.MjSpec()
    spec.modelname = f"mapush_{task_cfg['name']}"
    spec.option.timestep = sim_cfg["timestep"]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    world = spec.worldbody
    half = sim_cfg["arena_size"] / 2
    world.add_geom(
        name="floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[half, half, 0.1],
        contype=FLOOR_BITS,
        conaffinity=FLOOR_BITS,
        friction=[sim_cfg["floor_friction"], 0.005, 0.0001],
        rgba=[0.8, 0.8, 0.8, 1],
    )
    add_walls(world, half, sim_cfg["wall_height"], sim_cfg["wall_thickness"])
    add_object(world, task_cfg["object"])
    marker = world.add_body(name=SUBGOAL_BODY, mocap=True, pos=[0, 0, 0.05])
    # Visual only, as the original's target.urdf: a flat red disc, r = 0.5 m, 0.1 m high.
    marker.add_geom(
        name="subgoal_disc",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[0.5, 0.05, 0],
        contype=0,
        conaffinity=0,
        rgba=[1, 0.1, 0.1, 0.4],
    )
    for k in range(obstacles):
        sx, sy, sz = obstacle_size
        block = world.add_body(name=OBSTACLE_BODY.format(k), mocap=True, pos=[PARKED + 3 * k, PARKED, sz / 2])
        block.add_geom(
            name=f"obstacle{k}_box",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[sx / 2, sy / 2, sz / 2],
            contype=OBJECT_BITS,
            conaffinity=OBJECT_BITS,
            rgba=[0.35, 0.35, 0.4, 1],
        )
    prefixes = robot_prefixes(task_cfg["num_agents"])
    for prefix in prefixes:
        spec.attach(lowlevel.robot_spec(), frame=world.add_frame(), prefix=prefix)
    if not sim_cfg["robot_contacts"]:
        exclude_teammates(spec, [b.name for b in lowlevel.robot_spec().bodies if b.name != "world"], prefixes)
    return spec


def exclude_teammates(spec: mujoco.MjSpec, bodies: list[str], prefixes: list[str]) -> None:
    """No contact between any body of one robot and any body of another (`sim.robot_contacts=false`): teammates
    pass through each other, each still touching the floor, the object, the walls and itself."""
    for (first, second), (a, b) in itertools.product(
        itertools.combinations(prefixes, 2), itertools.product(bodies, repeat=2)
    ):
        spec.add_exclude(bodyname1=first + a, bodyname2=second + b)


def add_walls(world, half: float, height: float, thickness: float) -> None:
    """Four static walls whose inner faces bound the square [-half, half]^2."""
    offset = half + thickness / 2
    for name, pos, size in (
        ("wall_east", [offset, 0], [thickness / 2, half + thickness, height / 2]),
        ("wall_west", [-offset, 0], [thickness / 2, half + thickness, height / 2]),
        ("wall_north", [0, offset], [half + thickness, thickness / 2, height / 2]),
        ("wall_south", [0, -offset], [half + thickness, thickness / 2, height / 2]),
    ):
        world.add_geom(
            name=name,
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[*pos, height / 2],
            size=size,
            contype=OBJECT_BITS,
            conaffinity=OBJECT_BITS,
            rgba=[0.5, 0.5, 0.55, 1],
        )


def add_object(world, object_cfg: dict) -> None:
    """The pushed object: a free body made of box and cylinder parts resting on the floor.

    Each part's mass is given; MuJoCo derives the body's centre of mass and inertia from the parts' geometry
    (solid, uniform density), unlike the original URDFs, whose inertias are far below the geometric values
    (docs/fidelity.md: e.g. the cylinder's Izz is 0.0417 there, 11.25 kg m^2 for a solid cylinder).
    """
    height = max(part_height(p) for p in object_cfg["parts"])
    sx, sy = object_cfg["start_xy"]
    body = world.add_body(name=OBJECT_BODY, pos=[sx, sy, height / 2])
    body.add_freejoint(name=OBJECT_JOINT)
    for k, part in enumerate(object_cfg["parts"]):
        px, py = part["pos"]
        common = dict(
            name=f"object_part{k}",
            pos=[px, py, 0.0],
            mass=part["mass"],
            contype=OBJECT_BITS,
            conaffinity=OBJECT_BITS,
            rgba=[0.9, 0.55, 0.2, 1],
        )
        if part["type"] == "box":
            sx_, sy_, sz_ = part["size"]
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[sx_ / 2, sy_ / 2, sz_ / 2], **common)
        elif part["type"] == "cylinder":
            radius, h = part["size"]
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[radius, h / 2, 0], **common)
        else:
            raise ValueError(f"unknown object part type {part['type']!r}; valid: box, cylinder")


def part_height(part: dict) -> float:
    """Full height of an object part, in m."""
    return part["size"][2] if part["type"] == "box" else part["size"][1]
