"""What the commands of the paper's experiments do (`mapush.cli.experiments` reads their arguments): sweep (also
ablate and scale), reproduce, tables, archive, stages adopt|rekey|fingerprint, compare. A command that fails
returns its exit code."""

from __future__ import annotations

import sys
from pathlib import Path

from mapush.commands.arguments import output_dir, output_file, seeds_of
from mapush.errors import BadInput

REPRODUCED = ("main", "scale", "ocb_ablation")
"""The experiments `mapush reproduce` runs, in order (the scalability study reuses the main table's stages)."""

TABLE_FILES = (".md", ".tex", ".csv", ".json", ".png")
"""What `mapush tables` writes into --out, by suffix."""


def sweep(overrides: list[str], dry_run: bool = False) -> int:
    """Run (or with `dry_run` plan) one sweep; its exit code."""
    from mapush.experiments.sweep import dry_run as print_plan
    from mapush.experiments.sweep import report, run_sweep

    _check_table(overrides)
    if dry_run:
        print_plan(overrides)
        return 0
    sweep_dir, finished, failed = run_sweep(overrides)
    return report(sweep_dir, finished, failed)


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


def reproduce(overrides: list[str], out: Path, dry_run: bool) -> int:
    """`mapush reproduce`: every sweep of `REPRODUCED`, then the archive and the tables; 1 when a sweep failed."""
    from mapush.experiments.sweep_axes import sweep_overrides

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
    codes = [sweep([f"experiment={name}", *overrides], dry_run) for name in REPRODUCED]
    if dry_run:
        return 0
    root = Path(keys.get("sweep_root", "runs"))
    archive(runs=root, out=out / "jobs")  # the results, kept in git beside the tables
    tables(runs=[root, out / "jobs"], out=out, only=[], overwrite=False)
    return 1 if any(codes) else 0


def tables(runs: list[Path], out: Path, only: list[str], overwrite: bool) -> None:
    """`mapush tables`: every table (or `only` these) from the jobs under `runs` (default: runs/ and the archive)
    into `out`; a table there with more filled cells is kept unless `overwrite`."""
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


def archive(runs: Path, out: Path | None) -> None:
    """`mapush archive`: every sweep job's result.json under `runs` copied into `out` (default: results/jobs)."""
    from mapush.experiments.archive import ARCHIVE, archive_results

    _check_runs_dir(runs)
    out = output_dir(out or ARCHIVE, "--out")
    written, unchanged = archive_results(runs, out)
    print(f"{out}: {len(written)} results written, {unchanged} already archived")


def adopt(runs: list[Path], overrides: list[str]) -> None:
    """`mapush stages adopt`: the runs that are stages the sweep of `overrides` plans, copied into its store."""
    from mapush.experiments.adopt import adopt as adopt_runs

    missing = [str(r) for r in runs if not (r / "config.yaml").is_file()]
    if missing:
        raise BadInput(f"--run {missing[0]!r} is not a run dir (no config.yaml); valid: a dir `mapush train` made")
    adopt_runs([r.resolve() for r in runs], overrides)


def rekey(old: Path, mid_run: Path, overrides: list[str]) -> int:
    """`mapush stages rekey`: the stages of the checkout `old` carried over to this commit; its exit code."""
    from mapush.config import load_run_config

    if not (old / "mapush").is_dir():
        raise BadInput(f"{str(old)!r} is not a mapush checkout (no mapush/ in it); valid: a checkout of another commit")
    load_run_config(mid_run)  # BadInput unless it is a run dir
    if not overrides:
        raise BadInput("mapush stages rekey needs the sweep's overrides; valid: e.g. experiment=main")
    from mapush.experiments.rekey import CheckoutFailed
    from mapush.experiments.rekey import rekey as rekey_stages

    try:
        return rekey_stages(old.resolve(), str(mid_run.resolve()), overrides)
    except CheckoutFailed as err:
        print(err, file=sys.stderr)
        return 1


def fingerprint(mid_run: Path) -> None:
    """`mapush stages fingerprint`: every level's numbers hashed, printed as a JSON line."""
    import json

    from mapush.config import load_run_config

    load_run_config(mid_run)  # BadInput unless it is a run dir
    from mapush.experiments.fingerprint import fingerprint as hashes

    print(json.dumps(hashes(str(mid_run))))


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


def compare(targets: list[str], overrides: list[str], episodes: int | None, seeds: str | None, out: Path) -> None:
    """`mapush compare`: the runs among `targets` evaluated as trained and with the overrides (those among
    `targets`, then `overrides`), into OUT.md and OUT.json."""
    if episodes is not None and episodes < 1:
        raise BadInput(f"--episodes {episodes} must be a positive count; valid: 1 or more")
    seed_list = seeds_of(seeds) if seeds else None
    overrides = [t for t in targets if "=" in t] + overrides  # a variadic argument takes the overrides too
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
