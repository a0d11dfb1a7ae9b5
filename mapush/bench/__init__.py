"""`mapush bench`: what a PPO iteration costs and where it goes (`throughput`), and how long training takes to reach
a given evaluated success (`learning`)."""

from mapush.bench.learning import run_learning_bench
from mapush.bench.throughput import run_bench

__all__ = ["run_bench", "run_learning_bench"]
