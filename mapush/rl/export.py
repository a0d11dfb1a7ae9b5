"""The deterministic actor as ONNX: one self-contained file with a dynamic batch dim, for runtimes without torch.

rsl-rl's own `export_policy_to_onnx` fixes the batch at 1 and writes the weights to a second file
(rsl-rl-lib 5.5.1), so mapush calls torch's exporter itself. It uses the TorchScript-based exporter
(`dynamo=False`), as mjlab does: on torch 2.13 it takes 0.1 s where the dynamo exporter takes 3-12 s (importing
onnxscript on first use), paid by every finished stage of a sweep. torch deprecates it; torch is pinned
(`tools/setup.sh`), and `tests/unit/rl/test_export.py` runs the file in onnxruntime against `policy.pt`.
"""

from __future__ import annotations

import contextlib
import logging
import warnings
from pathlib import Path

import torch

from mapush.atomic import replacing

ONNX_OPSET = 18


def export_onnx(actor: torch.nn.Module, obs_dim: int, path: Path) -> Path:
    """Write `actor` (observation `obs` (batch, obs_dim) -> `actions` (batch, a)) to `path` as ONNX, atomically.

    `actor` is an exportable rsl-rl MLP with its observation normalizer (`MLPModel.as_onnx()` or `.as_jit()`).
    """
    path = Path(path)
    with _quiet_exporter(), replacing(path) as tmp:
        torch.onnx.export(
            actor.to("cpu").eval(),
            (torch.zeros(1, obs_dim),),
            str(tmp),
            dynamo=False,  # the TorchScript-based exporter; it writes the weights inside the one file
            dynamic_axes={"obs": {0: "batch"}, "actions": {0: "batch"}},
            input_names=["obs"],
            output_names=["actions"],
            opset_version=ONNX_OPSET,
            verbose=False,  # no progress lines on stdout, where `mapush train` prints its run dir
        )
    return path


def export_torchscript(actor: torch.nn.Module, path: Path) -> Path:
    """Write `actor` (an rsl-rl MLP's `.as_jit()`) to `path` as TorchScript, atomically: `policy.pt` marks a
    finished run, so it never exists half-written."""
    path = Path(path)
    with replacing(path) as tmp:
        torch.jit.script(actor.to("cpu").eval()).save(str(tmp))
    return path


@contextlib.contextmanager
def _quiet_exporter():
    """Silence the exporter's warnings (torchvision ops it skips, deprecations inside torch) on stderr."""
    torch_onnx = logging.getLogger("torch.onnx")
    level = torch_onnx.level
    torch_onnx.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        torch_onnx.setLevel(level)
