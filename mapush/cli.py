"""The `mapush` command line: train, eval, bench, plan, sweep, ablate, scale, tables, logs, plot.

Every command takes Hydra overrides (`key=value`).
"""

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
    live: bool = typer.Option(False, "--live", help="Also stream env 0 to Foxglove (ws://127.0.0.1:log.live_port)."),
    name: str = typer.Option(
        "", "--name", help="Keep this evaluation apart (e.g. with overrides): eval_NAME.json, episodes_NAME.mcap."
    ),
) -> None:
    """Evaluate deterministically; writes eval.json (success rate, completion time) and episodes.mcap."""
    import json

    from mapush.eval.rollout import evaluate as run_eval

    seed_list = _int_list(seeds, "--seeds") if seeds else None
    if episodes is not None and episodes < 1:
        raise BadInput(f"--episodes {episodes} must be a positive count; valid: 1 or more")
    if name and not name.replace("-", "").replace("_", "").isalnum():
        raise BadInput(f"--name {name!r} is not a plain name; valid: letters, digits, '-' and '_'")
    out = run_eval(target, episodes, seed_list, list(ctx.args), live=live, name=name)
    result = json.loads(out.read_text())
    runs = f"{result['episodes']} episodes x seeds {result['seeds']}"
    if "velocity_error" in result:  # the low level
        print(
            f"velocity error {result['velocity_error']:.3f} m/s | fall rate {100 * result['fall_rate']:.1f} % | {runs}"
        )
    else:
        print(
            f"success rate {100 * result['success_rate']:.1f} +- {100 * result['success_rate_std']:.1f} % | "
            f"completion time {result['completion_time']:.3f} ({result['completion_time_s']:.2f} s) | {runs}"
        )
    print(out)


@app.command(context_settings=PASS_THROUGH)
def bench(
    ctx: typer.Context,
    json_path: Path | None = typer.Option(None, "--json", help="Also write the figures to this JSON file."),
    learn: bool = typer.Option(
        False,
        "--learn",
        help="Time to success: train for --minutes, evaluate checkpoints, report the minutes to "
        "bench.learn.thresholds (JSON, and a PNG beside --json).",
    ),
    minutes: float = typer.Option(10.0, "--minutes", help="--learn: wall time of training."),
) -> None:
    """Measure throughput and where an iteration's time goes (architecture section 7), or with --learn the
    minutes of `mapush train` to a given evaluated success."""
    import json

    from mapush import bench as benchmarks
    from mapush.config import compose_config

    cfg = compose_config(list(ctx.args))
    if learn:
        if minutes <= 0:
            raise BadInput(f"--minutes {minutes} must be positive; valid: a number of minutes > 0")
        result = benchmarks.run_learning_bench(cfg, list(ctx.args), minutes, Path(cfg.bench.learn.run_root))
    else:
        result = benchmarks.run_bench(cfg)
    text = json.dumps(result, indent=2)
    print(text)
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(text + "\n")
        if learn:
            benchmarks.learning.plot_learning(result, json_path.with_suffix(".png"))


@app.command(context_settings=PASS_THROUGH)
def plan(
    ctx: typer.Context,
    task: str = typer.Option("cuboid", "--task", help="The object (conf/task/)."),
    seed: int = typer.Option(0, "--seed", help="The map: the one evaluation draws for this seed."),
    json_path: Path | None = typer.Option(None, "--json", help="Write start, goal, path, obstacles, time, validity."),
    png: Path | None = typer.Option(None, "--png", help="Draw the map and the path."),
    maps: int = typer.Option(1, "--maps", help="Plan this many maps (seeds SEED..) and print timing figures."),
) -> None:
    """Plan the object's path through a random long-horizon map with OMPL (level=high's planner settings)."""
    import json

    from mapush import plan as planning
    from mapush.config import compose_config, to_plain

    if maps < 1:
        raise BadInput(f"--maps {maps} must be 1 or more")
    cfg = to_plain(compose_config(["level=high", f"task={task}", f"seed={seed}", *ctx.args]))
    planner = planning.make_planner(cfg)
    try:
        record, _ = planning.plan_map(cfg, seed, planner)
        state = "valid" if record["valid"] else ("INVALID" if record["solved"] else "no path found (planner failure)")
        print(
            f"{task} seed {seed}: {record['planner']} path {record['length_m']:.2f} m, "
            f"{1000 * record['planning_time_s']:.1f} ms, {len(record['obstacles'])} obstacles, {state}"
        )
        if maps > 1:
            t = planning.timing(cfg, seed, maps, planner)
            print(
                f"{t['maps']} maps: median {1000 * t['median_s']:.1f} ms, max {1000 * t['max_s']:.1f} ms, "
                f"solved {t['solved']}, valid {t['valid']}"
            )
            record["timing"] = t
    finally:
        planner.close()
    if json_path:
        json_path.write_text(json.dumps(record, indent=2) + "\n")
        print(json_path)
    if png:
        print(planning.draw(cfg, record, png))


DRY_RUN = typer.Option(False, "--dry-run", help="Print the stages it would train and reuse; train nothing.")


@app.command(context_settings=PASS_THROUGH)
def sweep(ctx: typer.Context, dry_run: bool = DRY_RUN) -> None:
    """Run a Hydra multirun of sweep jobs: `method=ours,sa task=cuboid,tblock seed=0,1 launcher=local|slurm|ray`.

    Axes not given come from the experiment (`experiment=main|ocb_ablation|scale`, `budget=quick|paper`). Each job
    trains its method's stages and evaluates them into <sweep dir>/<job>/result.json; finished jobs are skipped
    and cut ones resumed when the same command runs again. A stage that any sweep under the same root has
    trained with the same config is reused, not trained again.
    """
    _sweep(list(ctx.args), dry_run)


@app.command(context_settings=PASS_THROUGH)
def ablate(
    ctx: typer.Context,
    what: str = typer.Argument(..., help="The ablation: ocb (the paper's OCB ablation)."),
    dry_run: bool = DRY_RUN,
) -> None:
    """The paper's OCB ablation: with and without OCB, timeouts 20 s and 40 s, several seeds (a sweep)."""
    if what != "ocb":
        raise BadInput(f"unknown ablation {what!r}; valid: ocb")
    _sweep(["experiment=ocb_ablation", *ctx.args], dry_run)


@app.command(context_settings=PASS_THROUGH)
def scale(
    ctx: typer.Context,
    agents: str = typer.Option("1,2,3,4", "--agents", help="Comma-separated robot counts."),
    dry_run: bool = DRY_RUN,
) -> None:
    """The cylinder scalability study: the whole hierarchy with each robot count, several seeds (a sweep)."""
    counts = _int_list(agents, "--agents")
    if not counts or min(counts) < 1:
        raise BadInput(f"--agents {agents!r} must be robot counts >= 1, e.g. 1,2,3,4")
    _sweep(["experiment=scale", f"agents={','.join(map(str, counts))}", *ctx.args], dry_run)


def _sweep(overrides: list[str], dry_run: bool = False) -> None:
    from mapush.experiments.sweep import dry_run as print_plan
    from mapush.experiments.sweep import report, run_sweep

    if dry_run:
        print_plan(overrides)
        return
    sweep_dir, finished, failed = run_sweep(overrides)
    code = report(sweep_dir, finished, failed)
    if code:
        raise typer.Exit(code)


@app.command(context_settings=PASS_THROUGH)
def calibrate(
    ctx: typer.Context,
    tasks: str = typer.Option("cuboid,tblock,cylinder", "--tasks", help="Objects to push, comma-separated."),
    steps: str = typer.Option("0.25,0.5", "--steps", help="Step command sizes (m/s, rad/s), comma-separated."),
    settle: float = typer.Option(1.0, "--settle", help="Seconds of standing before each step."),
    duration: float = typer.Option(3.0, "--duration", help="Seconds each step command is held."),
    out: Path | None = typer.Option(None, "--out", help="Output dir (default runs/calibrate/<time>)."),
    config: Path | None = typer.Option(None, "--config", help="The tracker config to update (default conf's)."),
) -> None:
    """Fit the tracker's lag and force limit to the legged Go1's step responses, free and pushing each object.

    Overrides choose the robot measured: `lowlevel.policy=RUN/policy.pt` (default: lowlevel=go1, shipped policy).
    """
    import datetime

    from mapush.calibrate import calibrate as run_calibration
    from mapush.calibrate import default_config_path
    from mapush.config import group_options

    task_list = [t for t in tasks.split(",") if t]
    unknown = sorted(set(task_list) - set(group_options("task")))
    if unknown or not task_list:
        raise BadInput(f"--tasks {tasks!r}: unknown {unknown}; valid: {', '.join(group_options('task'))}")
    step_sizes = [float(x) for x in steps.split(",") if x]
    if not step_sizes or min(step_sizes) <= 0:
        raise BadInput(f"--steps {steps!r} must be positive sizes, e.g. 0.25,0.5")
    if settle < 0 or duration <= 0:
        raise BadInput(f"--settle {settle} / --duration {duration}: valid: settle >= 0, duration > 0 seconds")
    overrides = list(ctx.args)
    reference = overrides if any(o.startswith("lowlevel=") for o in overrides) else ["lowlevel=go1", *overrides]
    stamp = datetime.datetime.now().strftime("%Y-%m-%d_%H-%M-%S")
    out_dir = out or Path("runs") / "calibrate" / stamp
    config_path = config or default_config_path()
    summary = run_calibration(reference, task_list, step_sizes, settle, duration, out_dir, config_path)
    fitted = ", ".join(f"{k} {v:.4g}" for k, v in summary["fitted"].items())
    print(f"fitted {fitted} -> {config_path}")
    print(out_dir)


@app.command()
def tables(
    runs: Path = typer.Option(Path("runs"), "--runs", help="Where to look for sweep jobs (result.json files)."),
    out: Path = typer.Option(Path("results"), "--out", help="Where to write the tables."),
    only: list[str] = typer.Option([], "--table", help="Write only these tables (main, ocb_ablation, scale)."),
) -> None:
    """Build the paper's tables (Markdown, LaTeX, CSV, a JSON sidecar per table), learning curves and the
    scalability plot."""
    from mapush.report.tables import BUILDERS, write_tables

    if not runs.is_dir():
        raise BadInput(f"--runs {str(runs)!r} is not a directory; valid: a dir holding sweep jobs (e.g. runs)")
    for name in only:
        if name not in BUILDERS:
            raise BadInput(f"--table {name!r} is not a table; valid: {', '.join(BUILDERS)}")
    for table in write_tables(runs, out, only or list(BUILDERS)):
        filled = sum(bool(c.values) for _, cells in table.rows for c in cells)
        total = sum(len(cells) for _, cells in table.rows)
        missing = f", missing cells listed in {table.name}.md" if table.missing else ""
        print(f"{out / table.name}.{{md,tex,csv,json}}: {filled}/{total} cells filled{missing}")


logs = typer.Typer(no_args_is_help=True, help="Inspect and repair MCAP logs (metrics.mcap, episodes.mcap).")
app.add_typer(logs, name="logs")


@logs.command()
def summary(file: Path = typer.Argument(..., help="An .mcap file, finished or cut.")) -> None:
    """Print the topics (schema, message count), the time span and whether the file is complete."""
    from datetime import UTC, datetime

    from mapush.logging.mcap_files import summary as read_summary

    info = read_summary(file)
    state = "complete" if info["complete"] else "CUT (no index: run `mapush logs recover` for an indexed copy)"
    print(f"{info['file']}: {state}")
    if info["messages"]:
        start = datetime.fromtimestamp(info["start_ns"] / 1e9, tz=UTC).isoformat(timespec="milliseconds")
        print(f"{info['messages']} messages over {info['duration_s']:.3f} s from {start}")
    else:
        print("0 messages")
    width = max((len(t) for t in info["topics"]), default=5)
    for topic, row in info["topics"].items():
        print(f"  {topic:<{width}}  {row['messages']:>8}  {row['schema']}")
    for kind in ("metadata", "attachments"):
        if info[kind]:
            print(f"{kind}: {', '.join(info[kind])}")


@logs.command()
def recover(
    file: Path = typer.Argument(..., help="A cut .mcap file (e.g. from a killed run)."),
    out: Path = typer.Option(..., "-o", "--out", help="Where to write the readable, indexed copy."),
) -> None:
    """Copy every complete record of a cut MCAP file into a readable, indexed file."""
    from mapush.logging.mcap_files import recover as recover_file

    if out.resolve() == file.resolve():
        raise BadInput(f"-o {str(out)!r} is the input file; valid: another path (the original is kept)")
    result = recover_file(file, out)
    cut = "" if result["complete_source"] else " (the source was cut)"
    print(f"recovered {result['messages']} messages{cut} into {result['file']}")


@logs.command(context_settings=PASS_THROUGH)
def layout(
    ctx: typer.Context,
    out: Path | None = typer.Option(None, "-o", "--out", help="Write here instead of printing."),
) -> None:
    """The Foxglove layout (3D scene, command and reward plots, episode log) for a config's episode files."""
    from mapush.config import compose_config, to_plain
    from mapush.logging.layout import episode_layout
    from mapush.rewards.manager import RewardManager

    cfg = to_plain(compose_config(list(ctx.args)))
    text = episode_layout(list(RewardManager(cfg["reward"]["terms"]).terms)).to_json()
    if out is None:
        print(text)
    else:
        out.write_text(text + "\n")
        print(out)


@app.command()
def plot(
    run_dirs: list[Path] = typer.Argument(..., help="Run dirs; runs differing only in seed become mean +- std."),
    out: Path | None = typer.Option(
        None, "-o", "--out", help="PNG (default: RUN_DIR/curves.png, or ./curves.png for several runs)."
    ),
    smooth: int = typer.Option(5, "--smooth", help="Moving-average window in logged points (1 = raw)."),
) -> None:
    """Draw learning curves (success rate, reward terms) from metrics.mcap as a PNG."""
    from mapush.plot import plot_runs

    if out is None:
        out = run_dirs[0] / "curves.png" if len(run_dirs) == 1 else Path("curves.png")
    print(plot_runs(run_dirs, out, smooth))


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
    except KeyboardInterrupt:
        print(
            "mapush: interrupted; logs are closed (a run continues with `mapush train --resume RUN_DIR`)",
            file=sys.stderr,
        )
        sys.exit(130)
