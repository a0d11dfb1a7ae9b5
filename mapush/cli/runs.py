"""Commands on one run: train, eval, play, ship, export (what they do: `mapush.commands.run_commands`)."""

from __future__ import annotations

from pathlib import Path

import typer

from mapush.cli.app import PASS_THROUGH, app, groups_epilog
from mapush.commands import run_commands


@app.command(context_settings=PASS_THROUGH, epilog=groups_epilog())
def train(
    ctx: typer.Context,
    resume: Path | None = typer.Option(None, "--resume", help="Continue this cut run from its last checkpoint."),
    show: str | None = typer.Option(None, "--cfg", help="Print the composed config (job, hydra, all); no training."),
) -> None:
    """Train a policy (default: mid level, cuboid, 2 robots, tracker). Prints the run dir."""
    run_commands.train(list(ctx.args), resume, show)


@app.command(name="eval", context_settings=PASS_THROUGH)
def evaluate(
    ctx: typer.Context,
    target: Path = typer.Argument(..., help="A run dir (its latest checkpoint) or a model_<it>.pt file."),
    episodes: int | None = typer.Option(None, "--episodes", help="Trials per seed (default: eval.episodes)."),
    seeds: str | None = typer.Option(None, "--seeds", help="Comma-separated seeds (default: eval.seeds)."),
    live: bool = typer.Option(False, "--live", help="Also stream env 0 to Foxglove (ws://127.0.0.1:log.live_port)."),
    name: str = typer.Option(
        "", "--name", help="Keep this evaluation apart (e.g. with overrides): eval_NAME.json, episodes_NAME.mcap."
    ),
    video: bool = typer.Option(
        False,
        "--video",
        help="Also render env 0's first episode(s) headless to eval_video.mp4, whole up to log.video.max_seconds "
        "(600 s of sim time) per file: log.video.fps (5) frames per sim second, played log.video.speedup (4)x.",
    ),
) -> None:
    """Evaluate deterministically; writes eval.json (success rate, completion time) and episodes.mcap."""
    run_commands.evaluate(target, episodes, seeds, list(ctx.args), live, name, video)


@app.command(context_settings=PASS_THROUGH)
def play(
    ctx: typer.Context,
    target: Path = typer.Argument(..., help="A run dir (its latest checkpoint) or a model_<it>.pt file."),
    seed: int = typer.Option(0, "--seed", help="The episodes' seed."),
) -> None:
    """Watch the policy push in MuJoCo's native viewer (needs a display), episode after episode, in real time."""
    run_commands.play(target, list(ctx.args), seed)


@app.command()
def ship(
    run: Path = typer.Argument(..., help="A finished run dir (a high level ships with its frozen mid level)."),
    out: Path = typer.Argument(..., help="The slim run dir to write (replaced), e.g. mapush/policies/cuboid."),
    episodes: int = typer.Option(50, "--episodes", help="Trials per seed of the shipped files' evaluation."),
    seeds: str = typer.Option("0,1", "--seeds", help="Comma-separated seeds of that evaluation."),
) -> None:
    """Ship a finished run as a slim run dir (actor, config, TorchScript and ONNX policies) and evaluate it."""
    run_commands.ship(run, out, episodes, seeds)


@app.command()
def export(
    run: Path = typer.Argument(..., help="A run dir made by `mapush train`, finished or cut (Ctrl-C)."),
    checkpoint: Path | None = typer.Option(None, "--checkpoint", help="A model_<it>.pt of it (default: the last)."),
    out: Path | None = typer.Option(None, "-o", "--out", help="A new dir (default: RUN/export_<iteration>)."),
) -> None:
    """Export one checkpoint's policy (policy.onnx, policy.pt) to a new dir, leaving the run as it is: the policy of
    a run cut before its end, or of any checkpoint."""
    run_commands.export(run, checkpoint, out)
