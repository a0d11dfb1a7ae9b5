"""mapush: hierarchical multi-agent quadruped pushing (MAPush, Feng et al. 2024) on MuJoCo and rsl-rl.

The Python API (`mapush.make_env`, `mapush.load_policy`, `mapush.VectorEnv`, `mapush.SingleEnv`) is imported on
first use, so that `import mapush.config` and the command line's start stay light (no torch, no MuJoCo).
"""

from __future__ import annotations

__version__ = "0.1.0"

_API = ("make_env", "load_policy", "compose")
"""Names of `mapush.api`: configs, envs and trained policies."""
_GYM = ("VectorEnv", "SingleEnv")
"""Names of `mapush.gym`: the gymnasium views of an env."""

__all__ = ["BadInput", "__version__", *_API, *_GYM]


def __getattr__(name: str):
    """Import an API name's module when the name is first used (PEP 562)."""
    if name in _API:
        from mapush import api as module
    elif name in _GYM:
        from mapush import gym as module
    elif name == "BadInput":
        from mapush import errors as module
    else:
        raise AttributeError(f"module 'mapush' has no attribute {name!r}")
    value = getattr(module, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
