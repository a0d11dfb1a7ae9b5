"""Commands of the paper's experiments: sweep, ablate, scale (Hydra multiruns) and tables."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from mapush.cli.app import PASS_THROUGH, app, number_list, output_dir, output_file, seeds_of
from mapush.errors import BadInput

DRY_RUN = typer.Option(False, "--dry-run", help="Print the stages it would train and reuse; train nothing.")


def _sweep_help() -> str:
    """`mapush sweep`'s help, naming the experiments and budgets that conf/experiment/*.yaml hold now."""
    from mapush.config import group_file, group_options

    names = group_options("experiment")
    budgets = sorted({b for name in names for b in group_file("experiment", name).get("budgets", {})})
    return (
        "Run a Hydra multirun of sweep jobs: `method=ours,sa task=cuboid,tblock seed=0,1 launcher=local|slurm|ray`."
        f"\n\nAxes not given come from the experiment (`experiment={'|'.join(names)}`, `budget={'|'.join(budgets)}`"
        " as its file lists them; `debug=smoke` without a budget means `budget=smoke`). Each job trains its method's "
        "stages and evaluates them into <sweep dir>/<job>/result.json; finished jobs are skipped and cut ones resumed "
        "when the same command runs again. A stage that any sweep under the same root has trained with the same "
        "config is reused, not trained again."
    )


@app.command(context_settings=PASS_THROUGH, help=_sweep_help())
def sweep(ctx: typer.Context, dry_run: bool = DRY_RUN) -> None:
    """Run a Hydra multirun of sweep jobs (`_sweep_help`: the experiments and budgets it takes)."""
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
    agents: str | None = typer.Option(
        None, "--agents", help="Comma-separated robot counts (default: sweep.agents of conf/experiment/scale.yaml)."
    ),
    dry_run: bool = DRY_RUN,
) -> None:
    """The cylinder scalability study: the whole hierarchy with each robot count, several seeds (a sweep)."""
    counts = [] if agents is None else [f"agents={','.join(map(str, number_list(agents, '--agents', minimum=1)))}"]
    _sweep(["experiment=scale", *counts, *ctx.args], dry_run)


REPRODUCED = ("main", "scale", "ocb_ablation")
"""The experiments `mapush reproduce` runs, in order (the scalability study reuses the main table's stages)."""


@app.command(context_settings=PASS_THROUGH)
def reproduce(
    ctx: typer.Context,
    out: Path = typer.Option(Path("results"), "--out", help="Where to write the tables."),
    dry_run: bool = DRY_RUN,
) -> None:
    """Every table of the paper in one command: the main, scalability and OCB-ablation sweeps, then the tables.

    Overrides go to every sweep (`budget=paper`, `launcher=slurm`, ...). Like each sweep, it resumes where it was
    cut: run it again until every job has finished. A sweep with failed jobs does not stop the others; the
    tables are written from what finished, and the command exits 1. `--dry-run` prints each sweep's plan against
    the stage store as it is now, so a stage that an earlier sweep would train shows as `train` in both.
    """
    from mapush.experiments.sweep_axes import sweep_overrides

    overrides = list(ctx.args)
    keys = {o.partition("=")[0].lstrip("+~"): o.partition("=")[2].strip("'\"") for o in overrides}
    axes = [k for k in ("experiment", "method", "task", "agents") if k in keys]
    if axes:
        raise BadInput(
            f"{axes[0]}={keys[axes[0]]}: reproduce runs every experiment on its own axes; valid: other overrides "
            "(budget=, seed=, launcher=, sweep_root=, stage overrides)"
        )
    _check_tables_out(out)
    output_dir(out / "jobs", "--out")
    for name in REPRODUCED:  # every sweep's overrides checked before the first one trains
        sweep_overrides([f"experiment={name}", *overrides])
    codes = [_sweep([f"experiment={name}", *overrides], dry_run, stop=False) for name in REPRODUCED]
    if dry_run:
        return
    root = Path(keys.get("sweep_root", "runs"))
    archive(runs=root, out=out / "jobs")  # the results, kept in git beside the tables
    tables(runs=[root, out / "jobs"], out=out, only=[], overwrite=False)
    if any(codes):
        raise typer.Exit(1)


def _sweep(overrides: list[str], dry_run: bool = False, stop: bool = True) -> int:
    """Run (or with `dry_run` plan) one sweep; its exit code, raised as typer.Exit when `stop` and nonzero."""
    from mapush.experiments.sweep import dry_run as print_plan
    from mapush.experiments.sweep import report, run_sweep

    _check_table(overrides)
    if dry_run:
        print_plan(overrides)
        return 0
    sweep_dir, finished, failed = run_sweep(overrides)
    code = report(sweep_dir, finished, failed)
    if code and stop:
        raise typer.Exit(code)
    return code


def _check_table(overrides: list[str]) -> None:
    """Refuse an experiment whose `table:` no builder of `mapush tables` draws: it would train for hours unseen."""
    from mapush import config
    from mapush.experiments.sweep_axes import DEFAULTS
    from mapush.report.tables import BUILDERS

    given = [o.partition("=")[2] for o in overrides if o.partition("=")[0] == "experiment"]
    name = given[-1] if given else DEFAULTS["experiment"]
    if not (config.CONF_DIR / "experiment" / f"{name}.yaml").exists():
        return  # the sweep's own checks name the valid experiments
    table = config.group_file("experiment", name).get("table")
    if table not in BUILDERS:
        raise BadInput(f"experiment={name}: its file says table: {table}; valid: {', '.join(BUILDERS)}")


@app.command()
def tables(
    runs: list[Path] = typer.Option(
        [],
        "--runs",
        help="Where to look for sweep jobs (result.json files); repeatable. Default: runs and the "
        "archive results/jobs, where each exists.",
    ),
    out: Path = typer.Option(Path("results"), "--out", help="Where to write the tables."),
    only: list[str] = typer.Option([], "--table", help="Write only these tables (main, ocb_ablation, scale, team)."),
    overwrite: bool = typer.Option(
        False, "--overwrite", help="Replace a table in --out even where it has more filled cells than these runs give."
    ),
) -> None:
    """Build the paper's tables (Markdown, LaTeX, CSV, a JSON sidecar per table), learning curves and the
    scalability plot, from the jobs under `runs/` and those archived in `results/jobs/` (`mapush archive`). A table
    in --out with more filled cells than the runs give (they were lost, or made elsewhere) is kept as it is."""
    from mapush.experiments.archive import ARCHIVE
    from mapush.report.tables import BUILDERS, filled_cells, write_tables

    for root in runs:
        _check_runs_dir(root)
    _check_tables_out(out)
    for name in only:
        if name not in BUILDERS:
            raise BadInput(f"--table {name!r} is not a table; valid: {', '.join(BUILDERS)}")
    roots = runs or [root for root in (Path("runs"), ARCHIVE) if root.is_dir()]
    written, kept = write_tables(roots, out, only or list(BUILDERS), overwrite)
    for table in written:
        total = sum(len(cells) for _, cells in table.rows)
        missing = f", missing cells listed in {table.name}.md" if table.missing else ""
        print(f"{out / table.name}.{{md,tex,csv,json}}: {filled_cells(table)}/{total} cells filled{missing}")
    for table, earlier in kept:
        print(
            f"{out / table.name}.{{md,tex,csv,json}}: kept as it was ({earlier} cells filled; these runs give "
            f"{filled_cells(table)}; --overwrite replaces it)"
        )


@app.command()
def archive(
    runs: Path = typer.Option(Path("runs"), "--runs", help="The runs dir whose sweep jobs to archive."),
    out: Path | None = typer.Option(None, "--out", help="The archive (commit it). Default: results/jobs."),
) -> None:
    """Copy every sweep job's result.json into a folder small enough to commit (results/jobs/), with each stage's
    training time, so `mapush tables` still builds the tables when the runs are gone (a new machine)."""
    from mapush.experiments.archive import ARCHIVE, archive_results

    _check_runs_dir(runs)
    out = output_dir(out or ARCHIVE, "--out")
    written, unchanged = archive_results(runs, out)
    print(f"{out}: {len(written)} results written, {unchanged} already archived")


stages_app = typer.Typer(
    help="The shared store of trained stages: adopt runs trained by hand, carry stages over to a commit whose configs "
    "changed only their form (rekey), hash every level's numbers (fingerprint).",
    no_args_is_help=True,
)
app.add_typer(stages_app, name="stages")


@stages_app.command(context_settings=PASS_THROUGH)
def adopt(
    ctx: typer.Context,
    run: list[Path] = typer.Option(..., "--run", help="A run dir trained by hand (`mapush train`); repeat it."),
) -> None:
    """Copy the runs that are stages a sweep plans (the sweep's overrides follow, e.g. experiment=main
    method=ours task=cuboid) into its store, so `mapush sweep` with those overrides reuses them."""
    from mapush.experiments.adopt import adopt as adopt_runs

    missing = [str(r) for r in run if not (r / "config.yaml").is_file()]
    if missing:
        raise BadInput(f"--run {missing[0]!r} is not a run dir (no config.yaml); valid: a dir `mapush train` made")
    adopt_runs([r.resolve() for r in run], list(ctx.args))


@stages_app.command(context_settings=PASS_THROUGH)
def rekey(
    ctx: typer.Context,
    old: Path = typer.Argument(..., help="A checkout of the older commit (e.g. git worktree add /tmp/old COMMIT)."),
    mid_run: Path = typer.Argument(..., help="A mid-level cuboid run dir, for the fingerprints' high level."),
) -> None:
    """Carry the stages a sweep trained at an older commit over to this one, whose configs name them differently
    (the sweep's overrides follow, e.g. experiment=main); only if both commits' fingerprints agree, else exit 1."""
    from mapush.config import load_run_config

    if not (old / "mapush").is_dir():
        raise BadInput(f"{str(old)!r} is not a mapush checkout (no mapush/ in it); valid: a checkout of another commit")
    load_run_config(mid_run)  # BadInput unless it is a run dir
    if not ctx.args:
        raise BadInput("mapush stages rekey needs the sweep's overrides; valid: e.g. experiment=main")
    from mapush.experiments.rekey import CheckoutFailed
    from mapush.experiments.rekey import rekey as rekey_stages

    try:
        code = rekey_stages(old.resolve(), str(mid_run.resolve()), list(ctx.args))
    except CheckoutFailed as err:
        print(err, file=sys.stderr)
        raise typer.Exit(1) from None
    if code:
        raise typer.Exit(code)


@stages_app.command()
def fingerprint(
    mid_run: Path = typer.Argument(..., help="A mid-level cuboid run dir (mapush train debug=smoke will do)."),
) -> None:
    """Print every level's numbers hashed (seeded rollouts) as a JSON line: equal at two commits means a refactor
    changed no behaviour."""
    import json

    from mapush.config import load_run_config

    load_run_config(mid_run)  # BadInput unless it is a run dir
    from mapush.experiments.fingerprint import fingerprint as hashes

    print(json.dumps(hashes(str(mid_run))))


TABLE_FILES = (".md", ".tex", ".csv", ".json", ".png")
"""What `mapush tables` writes into --out, by suffix."""


def _check_tables_out(out: Path) -> None:
    """BadInput unless `out` (tables' --out) is a dir or nothing, and holds no dir or symlink where a table file
    goes: checked before the first table is written, so that none is half replaced."""
    output_dir(out, "--out")
    if out.is_dir():
        for entry in sorted(out.iterdir()):
            if entry.suffix in TABLE_FILES and (entry.is_dir() or entry.is_symlink()):
                output_file(entry, "--out holds")


def _check_runs_dir(runs: Path) -> None:
    """BadInput unless `runs` (a --runs value) is a directory."""
    if not runs.is_dir():
        raise BadInput(f"--runs {str(runs)!r} is not a directory; valid: a dir holding sweep jobs (e.g. runs)")


@app.command(context_settings=PASS_THROUGH)
def compare(
    ctx: typer.Context,
    targets: list[str] = typer.Argument(..., help="Run dirs, then the overrides to compare with (key=value)."),
    episodes: int | None = typer.Option(None, "--episodes", help="Trials per seed (default: eval.episodes)."),
    seeds: str | None = typer.Option(None, "--seeds", help="Comma-separated seeds (default: eval.seeds)."),
    out: Path = typer.Option(Path("results/compare"), "--out", help="Writes OUT.md and OUT.json."),
) -> None:
    """Evaluate runs as trained and with overrides (e.g. lowlevel=go1: the sim-to-sim check) into one table."""
    if episodes is not None and episodes < 1:
        raise BadInput(f"--episodes {episodes} must be a positive count; valid: 1 or more")
    seed_list = seeds_of(seeds) if seeds else None
    overrides = [t for t in targets if "=" in t] + list(ctx.args)  # a variadic argument takes the overrides too
    runs = [Path(t) for t in targets if "=" not in t]
    for suffix in (".md", ".json"):
        output_file(out.with_suffix(suffix), "--out")
    if not runs:
        raise BadInput("mapush compare needs run dirs; valid: mapush compare RUN_DIR... key=value...")
    from mapush.rundir import resolve_checkpoint

    for run in runs:  # a missing run is told before the simulator and PyTorch load
        resolve_checkpoint(run)
    from mapush.report.compare import compare_run, write_comparison

    rows = [compare_run(run, episodes, seed_list, overrides) for run in runs]
    print(write_comparison(rows, overrides, out), end="")
