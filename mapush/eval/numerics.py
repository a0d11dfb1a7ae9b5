"""Which machine a seeded evaluation ran on, in the terms that decide its figures: how the machine rounds.

A seeded evaluation repeats bit for bit on one machine, loaded or not. On another CPU it may not: PyTorch (and
the BLAS inside it) choose their kernels at run time by instruction set (AVX2, AVX-512, ...), kernels that sum in
another order round the last bit differently, and over a 160 s episode of a closed loop a last-bit difference can
change an episode's outcome. `machine_record()` says what such a figure depends on: the CPU, the versions of the
numeric libraries, and `numerics`, a hash of the bits of a fixed set of the computations a rollout makes (matrix
products, the policy's activations, trigonometry, a MuJoCo step). Two machines with the same record compute
alike; `eval.json` carries it so that a reproduction knows whether to expect the same bits or only the same
figures within the evaluation's own noise (docs/reproducibility.md).
"""

from __future__ import annotations

import functools
import hashlib
import platform
import sys
from importlib import metadata

import mujoco
import numpy as np
import torch

LIBRARIES = ("torch", "mujoco-core", "ompl", "numpy", "rsl-rl-lib")
"""The distributions whose versions a figure depends on."""

_BOX_ON_FLOOR = """
<mujoco>
  <option timestep="0.005"/>
  <worldbody>
    <geom type="plane" size="5 5 0.1" friction="0.3"/>
    <body pos="0 0 0.3" euler="3 5 10">
      <freejoint/>
      <geom type="box" size="0.3 0.2 0.25" mass="4"/>
    </body>
  </worldbody>
</mujoco>
"""
"""A box dropped, tilted, onto a floor with friction: contacts, the solver and the integrator in 200 steps."""


@functools.cache
def numerics_hash() -> str:
    """16 hex digits of the bits of fixed computations through torch, numpy and MuJoCo on this machine."""
    digest = hashlib.sha256()
    gen = torch.Generator().manual_seed(0)
    a, b = torch.randn(50, 256, generator=gen), torch.randn(256, 128, generator=gen)
    layer = torch.nn.Linear(128, 64)
    with torch.no_grad():
        layer.weight.copy_(torch.randn(64, 128, generator=gen))
        layer.bias.copy_(torch.randn(64, generator=gen))
        hidden = a @ b
        outputs = [hidden, layer(torch.nn.functional.elu(hidden)), torch.tanh(hidden), torch.exp(-hidden.abs())]
        angles = hidden[:, :8] * 10
        outputs += [torch.sin(angles), torch.cos(angles), torch.atan2(angles, hidden[:, 8:16])]
        outputs += [torch.linalg.vector_norm(hidden, dim=-1), hidden.sum(0), torch.sqrt(hidden.abs())]
    for tensor in outputs:
        digest.update(tensor.numpy().tobytes())
    x = np.random.default_rng(0).standard_normal(1000)
    digest.update(np.sin(x * 10).tobytes() + np.exp(x).tobytes() + np.hypot(x, x[::-1]).tobytes())
    model = mujoco.MjModel.from_xml_string(_BOX_ON_FLOOR)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=200)
    digest.update(data.qpos.tobytes() + data.qvel.tobytes())
    return digest.hexdigest()[:16]


def cpu_name() -> str:
    """The CPU's model name (Linux's /proc/cpuinfo; elsewhere what Python's `platform` says)."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.partition(":")[2].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "absent"


def machine_record() -> dict:
    """What a seeded figure depends on besides the code and the seed (`eval.json`'s `machine`)."""
    return {
        "cpu": cpu_name(),
        "arch": platform.machine(),
        "torch_cpu_capability": torch.backends.cpu.get_cpu_capability(),
        "python": ".".join(map(str, sys.version_info[:3])),
        "libraries": {name: _version(name) for name in LIBRARIES},
        "numerics": numerics_hash(),
    }


def computes_alike(a: dict | None, b: dict | None) -> bool:
    """Whether two machine records promise the same bits: same libraries, same kernels, same numerics hash.

    The CPU's name is left out (two models with the same instruction set round alike); a record that lacks a
    field (an `eval.json` written before machines were recorded) promises nothing.
    """
    keys = ("arch", "torch_cpu_capability", "libraries", "numerics")
    return bool(a and b) and all(k in a and k in b and a[k] == b[k] for k in keys)
