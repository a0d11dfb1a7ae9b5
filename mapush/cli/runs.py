"""Commands on one run: train, eval, play, ship, export."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from mapush.cli.app import PASS_THROUGH, app, groups_epilog, seeds_of
from mapush.errors import BadInput
from mapush.schema import NAME_LENGTH, SEED_MAX

CFG_PARTS = ("job", "hydra", "all")
"""What `--cfg` prints, as Hydra apps do: the composed config, Hydra's own node, or both."""


@app.command(context_settings=PASS_THROUGH, epilog=groups_epilog())
def train(
    ctx: typer.Context,
    resume: Path | None = typer.Option(None, "--resume", help="Continue this cut run from its last checkpoint."),
    show: str | None = typer.Option(None, "--cfg", help="Print the composed config (job, hydra, all); no training."),
) -> None:
    """Train a policy (default: mid level, cuboid, 2 robots, tracker). Prints the run dir."""
    from omegaconf import OmegaConf

    from mapush.config import compose_config, load_run_config
    from mapush.viz.preflight import prepare_training_video

    overrides = list(ctx.args)
    _refuse_multirun(overrides)
    if show is not None:
        if show not in CFG_PARTS:
            raise BadInput(f"--cfg {show!r} is not a part; valid: {', '.join(CFG_PARTS)}")
        cfg = compose_config(overrides, hydra=show != "job")
        print(OmegaConf.to_yaml({"hydra": cfg.hydra} if show == "hydra" else cfg), end="")
        return
    if resume is not None:
        iterations = None
        for override in overrides:
            key, _, value = override.partition("=")
            if key != "train.iterations" or not value.isdigit():
                raise BadInput(f"--resume takes only train.iterations=N as an override, got {override!r}")
            iterations = int(value)
        prepare_training_video(load_run_config(resume))  # before MuJoCo is imported: it picks the GL backend
        from mapush.commands import train as training

        training.resume(resume, iterations, command=f"mapush train --resume {resume} {' '.join(overrides)}".strip())
        return
    cfg = compose_config(overrides)
    prepare_training_video(cfg)
    from mapush.commands import train as training

    training.train(cfg, overrides, command=" ".join(["mapush", *sys.argv[1:]]))


def _refuse_multirun(overrides: list[str]) -> None:
    """Hydra's multirun habits (`-m`, `--multirun`, `seed=0,1`) answered with the `mapush sweep` line to use."""
    flags = [o for o in overrides if o in ("-m", "--multirun")]
    swept = [o for o in overrides if "=" in o and _is_sweep(o)]
    if flags or swept:
        raise BadInput(
            f"mapush train runs one config, not a sweep ({' '.join(flags + swept)}); valid: one value per key, or "
            f"`{_sweep_line([o for o in overrides if o not in flags])}` (sweeps train, evaluate and resume every "
            "combination)"
        )


def _sweep_line(overrides: list[str]) -> str:
    """The `mapush sweep` that trains what refused `overrides` ask for and no more: one method (ours: the mid
    level, then the high level on it), one task, and with `debug=smoke` the sweep's smoke budget (`budget=smoke`;
    without it a sweep plans the whole main experiment at its quick budget)."""
    task, rest = "cuboid", []
    for override in overrides:
        key, _, value = override.partition("=")
        if key.lstrip("+") == "task":
            task = value
        elif key.lstrip("+") == "train.run_root":
            rest.append(f"sweep_root={value}")  # a sweep's jobs go under its root
        elif key.lstrip("+~") not in ("level", "train.run_dir", "hydra.run.dir"):  # the method's stages, its dirs
            rest += ["budget=smoke", override] if override == "debug=smoke" else [override]
    return " ".join(["mapush sweep method=ours", f"task={task}", *rest])


def _is_sweep(override: str) -> bool:
    """Whether Hydra's grammar reads `override` as a sweep (`seed=0,1`, `seed=range(3)`); a parse error is left for
    the composition to report."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    try:
        return OverridesParser.create().parse_override(override).is_sweep_override()
    except Exception:  # Hydra's grammar errors have several types; compose_config names the mistake
        return False


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
    import json

    if video:  # before MuJoCo is imported: it picks the OpenGL backend
        from mapush.viz.preflight import require_offscreen_gl

        require_offscreen_gl()
    seed_list = seeds_of(seeds) if seeds else None
    if episodes is not None and episodes < 1:
        raise BadInput(f"--episodes {episodes} must be a positive count; valid: 1 or more")
    if name and not (name.replace("-", "").replace("_", "").isalnum() and len(name) <= NAME_LENGTH):
        shown = name if len(name) <= 80 else f"{name[:60]}... ({len(name)} characters)"
        raise BadInput(f"--name {shown!r} is not a plain name; valid: 1 to {NAME_LENGTH} letters, digits, '-' and '_'")
    from mapush.rundir import resolve_checkpoint

    run_dir, _ = resolve_checkpoint(target)  # a missing run is told before the simulator and PyTorch load
    from mapush.provenance import run_made_by_other_code

    if warning := run_made_by_other_code(run_dir):
        print(warning, file=sys.stderr)
    from mapush.eval.rollout import evaluate as run_eval

    out = run_eval(target, episodes, seed_list, list(ctx.args), live=live, name=name, video=video)
    result = json.loads(out.read_text())
    runs = f"{result['episodes']} episodes x seeds {result['seeds']}"
    if "velocity_error" in result:  # the low level
        print(
            f"velocity error {result['velocity_error']:.3f} m/s | yaw rate error {result['yaw_rate_error']:.3f} rad/s"
            f" | fall rate {100 * result['fall_rate']:.1f} % | {runs}"
        )
    else:
        print(
            f"success rate {100 * result['success_rate']:.1f} +- {100 * result['success_rate_std']:.1f} % | "
            f"completion time {result['completion_time']:.3f} ({result['completion_time_s']:.2f} s) | {runs}"
        )
    if video:
        from mapush.viz.video import eval_video_of

        print(eval_video_of(out))
    print(out)


@app.command(context_settings=PASS_THROUGH)
def play(
    ctx: typer.Context,
    target: Path = typer.Argument(..., help="A run dir (its latest checkpoint) or a model_<it>.pt file."),
    seed: int = typer.Option(0, "--seed", help="The episodes' seed."),
) -> None:
    """Watch the policy push in MuJoCo's native viewer (needs a display), episode after episode, in real time."""
    from mapush.viz.preflight import require_display

    if not 0 <= seed <= SEED_MAX:
        raise BadInput(f"--seed {seed} is not valid; valid: an integer in [0, {SEED_MAX}]")
    require_display()
    from mapush.eval.play import play as run_play

    run_play(target, list(ctx.args), seed)


@app.command()
def ship(
    run: Path = typer.Argument(..., help="A finished run dir (a high level ships with its frozen mid level)."),
    out: Path = typer.Argument(..., help="The slim run dir to write (replaced), e.g. mapush/policies/cuboid."),
    episodes: int = typer.Option(50, "--episodes", help="Trials per seed of the shipped files' evaluation."),
    seeds: str = typer.Option("0,1", "--seeds", help="Comma-separated seeds of that evaluation."),
) -> None:
    """Ship a finished run as a slim run dir (actor, config, TorchScript and ONNX policies) and evaluate it."""
    from mapush.commands.ship import ship as write_shipped

    if episodes < 1:
        raise BadInput(f"--episodes {episodes} must be a positive count; valid: 1 or more")
    print(write_shipped(run, out, episodes, seeds_of(seeds)))


@app.command()
def export(
    run: Path = typer.Argument(..., help="A run dir made by `mapush train`, finished or cut (Ctrl-C)."),
    checkpoint: Path | None = typer.Option(None, "--checkpoint", help="A model_<it>.pt of it (default: the last)."),
    out: Path | None = typer.Option(None, "-o", "--out", help="A new dir (default: RUN/export_<iteration>)."),
) -> None:
    """Export one checkpoint's policy (policy.onnx, policy.pt) to a new dir, leaving the run as it is: the policy of
    a run cut before its end, or of any checkpoint."""
    from mapush.cli.app import output_dir
    from mapush.commands.train import export_checkpoint
    from mapush.config import load_run_config
    from mapush.rundir import checkpoint_iteration, checkpoints

    load_run_config(run)  # BadInput unless a run dir
    found = checkpoints(run)
    if checkpoint is None and not found:
        raise BadInput(f"run dir {str(run)!r} has no checkpoint; valid: a run with model_*.pt")
    chosen = checkpoint or found[-1]
    if Path(chosen).resolve() not in [p.resolve() for p in found]:
        names = ", ".join(p.name for p in found) or "none"
        raise BadInput(f"--checkpoint {str(chosen)!r} is not a checkpoint of {str(run)!r}; valid: {names}")
    target = output_dir(out or Path(run) / f"export_{checkpoint_iteration(chosen)}", "--out")
    if target.exists():
        raise BadInput(f"--out {str(target)!r} exists; valid: a new dir (nothing is overwritten)")
    print(export_checkpoint(Path(run), Path(chosen), target))
