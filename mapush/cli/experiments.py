"""Commands of the paper's experiments: sweep, ablate, scale (Hydra multiruns) and tables (what they do:
`mapush.commands.experiment_commands`)."""

from __future__ import annotations

from pathlib import Path

import typer

from mapush.cli.app import PASS_THROUGH, app
from mapush.commands import experiment_commands
from mapush.commands.arguments import number_list
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
    _exit(experiment_commands.sweep(list(ctx.args), dry_run))


@app.command(context_settings=PASS_THROUGH)
def ablate(
    ctx: typer.Context,
    what: str = typer.Argument(..., help="The ablation: ocb (the paper's OCB ablation)."),
    dry_run: bool = DRY_RUN,
) -> None:
    """The paper's OCB ablation: with and without OCB, timeouts 20 s and 40 s, several seeds (a sweep)."""
    if what != "ocb":
        raise BadInput(f"unknown ablation {what!r}; valid: ocb")
    _exit(experiment_commands.sweep(["experiment=ocb_ablation", *ctx.args], dry_run))


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
    _exit(experiment_commands.sweep(["experiment=scale", *counts, *ctx.args], dry_run))


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
    _exit(experiment_commands.reproduce(list(ctx.args), out, dry_run))


def _exit(code: int) -> None:
    """A command's nonzero exit code as typer.Exit."""
    if code:
        raise typer.Exit(code)


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
    experiment_commands.tables(runs, out, only, overwrite)


@app.command()
def archive(
    runs: Path = typer.Option(Path("runs"), "--runs", help="The runs dir whose sweep jobs to archive."),
    out: Path | None = typer.Option(None, "--out", help="The archive (commit it). Default: results/jobs."),
) -> None:
    """Copy every sweep job's result.json into a folder small enough to commit (results/jobs/), with each stage's
    training time, so `mapush tables` still builds the tables when the runs are gone (a new machine)."""
    experiment_commands.archive(runs, out)


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
    experiment_commands.adopt(run, list(ctx.args))


@stages_app.command(context_settings=PASS_THROUGH)
def rekey(
    ctx: typer.Context,
    old: Path = typer.Argument(..., help="A checkout of the older commit (e.g. git worktree add /tmp/old COMMIT)."),
    mid_run: Path = typer.Argument(..., help="A mid-level cuboid run dir, for the fingerprints' high level."),
) -> None:
    """Carry the stages a sweep trained at an older commit over to this one, whose configs name them differently
    (the sweep's overrides follow, e.g. experiment=main); only if both commits' fingerprints agree, else exit 1."""
    _exit(experiment_commands.rekey(old, mid_run, list(ctx.args)))


@stages_app.command()
def fingerprint(
    mid_run: Path = typer.Argument(..., help="A mid-level cuboid run dir (mapush train debug=smoke will do)."),
) -> None:
    """Print every level's numbers hashed (seeded rollouts) as a JSON line: equal at two commits means a refactor
    changed no behaviour."""
    experiment_commands.fingerprint(mid_run)


@app.command(context_settings=PASS_THROUGH)
def compare(
    ctx: typer.Context,
    targets: list[str] = typer.Argument(..., help="Run dirs, then the overrides to compare with (key=value)."),
    episodes: int | None = typer.Option(None, "--episodes", help="Trials per seed (default: eval.episodes)."),
    seeds: str | None = typer.Option(None, "--seeds", help="Comma-separated seeds (default: eval.seeds)."),
    out: Path = typer.Option(Path("results/compare"), "--out", help="Writes OUT.md and OUT.json."),
) -> None:
    """Evaluate runs as trained and with overrides (e.g. lowlevel=go1: the sim-to-sim check) into one table."""
    experiment_commands.compare(targets, list(ctx.args), episodes, seeds, out)
