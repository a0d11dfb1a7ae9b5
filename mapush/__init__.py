"""mapush: hierarchical multi-agent quadruped pushing (MAPush, Feng et al. 2024) on MuJoCo and rsl-rl."""

__version__ = "0.1.0"
