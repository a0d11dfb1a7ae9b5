"""The configs' own resolvers: `${physx_average:...}` (friction as PhysX combines it), `${reciprocal:...}` and
`${original_collision_m:...}` (the original's robot-distance rule, `mapush.rules`)."""

from __future__ import annotations

from omegaconf import OmegaConf

from mapush.rules import original_collision_m


def physx_average(coefficients, other: float) -> list[float] | float:
    """The sliding friction of PhysX contacts between bodies of `coefficients` (a list, or one number) and one body
    of `other`: the average of the two, PhysX's default combine mode, which the original ran (docs/fidelity.md).

    MuJoCo takes the larger of a contact's two coefficients, so an object on a less frictional floor carries the
    averaged value itself (the task's `object.friction`). Rounded to 1e-9 so that 0.4 stays 0.4.
    """
    if isinstance(coefficients, int | float):
        return round((float(coefficients) + float(other)) / 2, 9)
    return [round((float(mu) + float(other)) / 2, 9) for mu in coefficients]


RESOLVERS = {
    "physx_average": physx_average,
    "reciprocal": lambda gain: 1.0 / float(gain),  # 1 / level.action_gain, where a mid-level command saturates
    "original_collision_m": original_collision_m,
}


def register_resolvers() -> None:
    """Register `RESOLVERS` with OmegaConf (once: a second call leaves them)."""
    for name, resolver in RESOLVERS.items():
        if not OmegaConf.has_resolver(name):
            OmegaConf.register_new_resolver(name, resolver)
