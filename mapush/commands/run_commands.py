"""What the commands on one run do (`mapush.cli.runs` reads their arguments): train, eval, play, ship, export."""

from __future__ import annotations

import sys
from pathlib import Path

from mapush.commands.arguments import output_dir, seeds_of
from mapush.config_terms import check_replaced_events
from mapush.errors import BadInput

CFG_PARTS = ("job", "hydra", "all")
"""What `--cfg` prints, as Hydra apps do: the composed config, Hydra's own node, or both."""


def train(overrides: list[str], resume: Path | None, show: str | None) -> None:
    """`mapush train`: print the composed config (`show`), continue a cut run (`resume`) or train a fresh one."""
    from omegaconf import OmegaConf

    from mapush.config import compose_config, load_run_config, to_plain
    from mapush.envs.spawn_ring import check_spawn
    from mapush.viz.preflight import prepare_training_video

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
        run_cfg = load_run_config(resume)
        if iterations is not None and iterations > int(run_cfg.train.iterations):  # lengthening rewrites meta.json:
            from mapush.config import META_FILE  # one cut or altered is told before training's imports, not after
            from mapush.records import read_meta

            read_meta(Path(resume) / META_FILE)
        prepare_training_video(run_cfg)  # before MuJoCo is imported: it picks the GL backend
        from mapush import training

        training.resume(resume, iterations, command=f"mapush train --resume {resume} {' '.join(overrides)}".strip())
        return
    cfg = compose_config(overrides)
    _probe_path(Path(cfg.train.get("run_dir") or cfg.train.run_root))
    check_replaced_events("level.eval_events", cfg.level.get("events"), cfg.level.get("eval_events"))
    check_spawn(to_plain(cfg))  # the env checks it again; here before training's imports
    prepare_training_video(cfg)
    from mapush import training  # seconds of torch, rsl-rl and MuJoCo: after what can be refused without them

    training.train(cfg, overrides, command=" ".join(["mapush", *sys.argv[1:]]))


def _probe_path(path: Path) -> None:
    """The OSError the filesystem gives a run dir's path that it can never hold (a name or path too long, a loop
    of links), before training's imports rather than after them; a path that does not exist yet passes."""
    import errno
    import os

    try:
        os.stat(path)
    except OSError as err:
        if err.errno in (errno.ENAMETOOLONG, errno.ELOOP):
            raise


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


def evaluate(
    target: Path, episodes: int | None, seeds: str | None, overrides: list[str], live: bool, name: str, video: bool
) -> None:
    """`mapush eval`: evaluate deterministically into eval.json and episodes.mcap; print the figures and the file."""
    import json

    if video:  # before MuJoCo is imported: it picks the OpenGL backend
        from mapush.viz.preflight import require_offscreen_gl

        require_offscreen_gl()
    seed_list = seeds_of(seeds) if seeds else None
    if episodes is not None and episodes < 1:
        raise BadInput(f"--episodes {episodes} must be a positive count; valid: 1 or more")
    _check_name(name)
    from mapush.config.groups import check_groups

    check_groups(overrides)  # an unknown option of a group (rules=lenient) before the simulator and PyTorch load
    from mapush.rundir import resolve_checkpoint

    run_dir, _ = resolve_checkpoint(target)  # a missing run is told before the simulator and PyTorch load
    from mapush.config import apply_overrides, load_run_config

    apply_overrides(load_run_config(run_dir), overrides)  # so is a bad override or value (a seed numpy cannot take)
    from mapush.provenance import run_made_by_other_code

    if warning := run_made_by_other_code(run_dir):
        print(warning, file=sys.stderr)
    from mapush.eval.rollout import evaluate as run_eval

    out = run_eval(target, episodes, seed_list, overrides, live=live, name=name, video=video)
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


def _check_name(name: str) -> None:
    """BadInput unless `name` (eval's --name) is empty or a plain name of at most `NAME_LENGTH` characters."""
    from mapush.schema import NAME_LENGTH

    if name and not (name.replace("-", "").replace("_", "").isalnum() and len(name) <= NAME_LENGTH):
        shown = name if len(name) <= 80 else f"{name[:60]}... ({len(name)} characters)"
        raise BadInput(f"--name {shown!r} is not a plain name; valid: 1 to {NAME_LENGTH} letters, digits, '-' and '_'")


def play(target: Path, overrides: list[str], seed: int) -> None:
    """`mapush play`: the policy in MuJoCo's native viewer, episode after episode."""
    from mapush.schema import SEED_MAX
    from mapush.viz.preflight import require_display

    if not 0 <= seed <= SEED_MAX:
        raise BadInput(f"--seed {seed} is not valid; valid: an integer in [0, {SEED_MAX}]")
    require_display()
    from mapush.eval.play import play as run_play

    run_play(target, overrides, seed)


def ship(run: Path, out: Path, episodes: int, seeds: str) -> None:
    """`mapush ship`: a finished run as a slim run dir, evaluated; prints where it went."""
    from mapush.commands.ship import ship as write_shipped

    if episodes < 1:
        raise BadInput(f"--episodes {episodes} must be a positive count; valid: 1 or more")
    print(write_shipped(run, out, episodes, seeds_of(seeds)))


def export(run: Path, checkpoint: Path | None, out: Path | None) -> None:
    """`mapush export`: one checkpoint's policy (policy.onnx, policy.pt) into a new dir; prints the dir."""
    from mapush.config import load_run_config
    from mapush.rundir import checkpoint_iteration, checkpoints
    from mapush.training import export_checkpoint

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
