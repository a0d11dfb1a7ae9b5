"""The `mapush` command line: train, eval, bench. Every command takes Hydra overrides (`key=value`)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl imports GitPython; no git binary must not kill us

import typer

from mapush.errors import BadInput

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Hierarchical multi-agent quadruped pushing (MAPush) on MuJoCo and rsl-rl.",
)
PASS_THROUGH = {"allow_extra_args": True, "ignore_unknown_options": True}


@app.command(context_settings=PASS_THROUGH)
def train(
    ctx: typer.Context,
    resume: Path | None = typer.Option(None, "--resume", help="Continue this cut run from its last checkpoint."),
) -> None:
    """Train a policy (default: mid level, cuboid, 2 robots, tracker). Prints the run dir."""
    from mapush import train as training
    from mapush.config import compose_config

    overrides = list(ctx.args)
    if resume is not None:
        iterations = None
        for override in overrides:
            key, _, value = override.partition("=")
            if key != "train.iterations" or not value.isdigit():
                raise BadInput(f"--resume takes only train.iterations=N as an override, got {override!r}")
            iterations = int(value)
        training.resume(resume, iterations)
        return
    cfg = compose_config(overrides)
    training.train(cfg, overrides, command=" ".join(["mapush", *sys.argv[1:]]))


@app.command(name="eval", context_settings=PASS_THROUGH)
def evaluate(
    ctx: typer.Context,
    target: Path = typer.Argument(..., help="A run dir (its latest checkpoint) or a model_<it>.pt file."),
    episodes: int | None = typer.Option(None, "--episodes", help="Trials per seed (default: eval.episodes)."),
    seeds: str | None = typer.Option(None, "--seeds", help="Comma-separated seeds (default: eval.seeds)."),
) -> None:
    """Evaluate deterministically; writes eval.json (success rate, completion time) into the run dir."""
    import json

    from mapush.eval.rollout import evaluate as run_eval

    seed_list = _int_list(seeds, "--seeds") if seeds else None
    if episodes is not None and episodes < 1:
        raise BadInput(f"--episodes {episodes} must be a positive count; valid: 1 or more")
    out = run_eval(target, episodes, seed_list, list(ctx.args))
    result = json.loads(out.read_text())
    print(
        f"success rate {100 * result['success_rate']:.1f} +- {100 * result['success_rate_std']:.1f} % | "
        f"completion time {result['completion_time']:.3f} ({result['completion_time_s']:.2f} s) | "
        f"{result['episodes']} episodes x seeds {result['seeds']}"
    )
    print(out)


@app.command(context_settings=PASS_THROUGH)
def bench(
    ctx: typer.Context,
    json_path: Path | None = typer.Option(None, "--json", help="Also write the figures to this JSON file."),
) -> None:
    """Measure env, raw-physics and training throughput and peak memory (architecture section 7)."""
    import json

    from mapush.bench import run_bench
    from mapush.config import compose_config

    result = run_bench(compose_config(list(ctx.args)))
    text = json.dumps(result, indent=2)
    print(text)
    if json_path:
        json_path.write_text(text + "\n")


def _int_list(text: str, flag: str) -> list[int]:
    try:
        return [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise BadInput(f"{flag} {text!r} must be comma-separated integers, e.g. 0,1,2,3") from None


def main() -> None:
    """Entry point: BadInput becomes one line on stderr and exit code 2."""
    try:
        app()
    except BadInput as err:
        print(f"mapush: error: {err}", file=sys.stderr)
        sys.exit(2)
