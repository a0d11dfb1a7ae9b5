"""`mapush bench`: what a PPO iteration costs and where it goes (`throughput`), how long training takes to reach
a given evaluated success (`learning`), and what a headless video costs (`rendering`)."""

from mapush.bench.learning import run_learning_bench
from mapush.bench.rendering import run_video_bench
from mapush.bench.throughput import run_bench

__all__ = ["run_bench", "run_learning_bench", "run_video_bench"]
