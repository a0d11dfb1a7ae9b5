"""Keep what the sweeps found when their runs are gone: `mapush archive` copies every job's `result.json` (and the
result it superseded) from a runs dir into a folder small enough to commit (`results/jobs/`, a few kB a job),
with each stage's training core-seconds measured from its run while it is there, and each stage's `stage.yaml`
(its identity, the config that trained it, and what it was adopted from).

The archive is laid out as a sweep root: `<archive>/<sweep>/<job>/result.json` and `<archive>/stages/<identity>/
stage.yaml`, whatever dir the jobs were archived from, so a job's stages resolve (and adopted stages count once)
as they did under `runs/`. A result holds everything a table needs (its evaluations, its learning curve, its
evaluation time); checkpoints and logs stay under `runs/`, which git ignores and a new machine does not have.
`mapush tables` reads the runs dir and the archive together; a job found in both counts once, the newer result.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import json
import shutil
from pathlib import Path

import hydra
import omegaconf
from omegaconf import DictConfig

from mapush.atomic import write_json
from mapush.config import compose_config
from mapush.errors import BadInput
from mapush.experiments.results import (
    RESULT,
    SUPERSEDED,
    Change,
    JobResult,
    every_stage_override,
    read_result,
    recorded_stage_seconds,
    searchpath_overrides,
    write_result,
)
from mapush.experiments.stage_plan import PlannedStage, applies, budget_of, planned_stages, stage_curve_specs
from mapush.experiments.stages import IDENTITY_FILE, STORE, identity_of, stage_dir, stands_for, store_root
from mapush.experiments.staleness import drawn_alike, result_changes, same_stages, still_valid

ARCHIVE = Path("results/jobs")
"""Where `mapush archive` writes and `mapush tables` also reads, relative to the working directory."""


def job_key(job_dir: Path | str) -> tuple[str, str]:
    """A job's name wherever it lies: (sweep dir, job dir), e.g. ("main_quick", "method=ours,seed=0,...")."""
    return Path(job_dir).parent.name, Path(job_dir).name


def _result_files(root: Path, skip: list[Path]) -> list[Path]:
    """Every job's current result under `root`, and the result it superseded, less those under the dirs `skip`.
    A superseded result whose job has no current one (running again now) is left out: until the new result
    exists, the archive keeps the old one as the job's current result, and a copy beside it would be named by no
    result."""
    current = list(Path(root).glob(f"**/{RESULT}"))
    found = [*current, *(p.parent / SUPERSEDED for p in current if (p.parent / SUPERSEDED).is_file())]
    skip = [s.resolve() for s in skip]
    return sorted(p for p in found if not any(s in p.resolve().parents for s in skip))


def archive_results(runs: Path, out: Path = ARCHIVE) -> tuple[list[Path], int]:
    """Copy every result under `runs` to `out/<sweep>/<job>/`, with each stage's core-seconds (measured from its
    run now, as `stage_core_seconds` counts them today, else the result's own, else an earlier archived copy's) and
    each stage's `stage.yaml` chain to `out/stages/`. Returns the files written and the number already archived
    unchanged."""
    Path(out).mkdir(parents=True, exist_ok=True)
    written, unchanged = [], 0
    for path in _result_files(runs, skip=[Path(out)]):
        result = read_result(path)
        runs_of = dict(zip(result.stages, result.stage_runs(), strict=True))
        target = Path(out).joinpath(*job_key(path.parent), path.name)
        archived = read_result(target) if target.is_file() else None
        earlier = archived.stage_core_s if archived else {}
        result.stage_core_s = {**earlier, **result.stage_core_s, **recorded_stage_seconds(runs_of)}
        result.archived_from = result.archived_from or str(path.parent)
        for run in runs_of.values():
            _archive_identity(run, Path(out))
        if archived and archived.record() == result.record():
            unchanged += 1  # archived before, alike (perhaps in an older format)
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        write_result(target, result)
        written.append(target)
    return written, unchanged


def _archive_identity(run: Path, out: Path) -> None:
    """Copy the `stage.yaml` of the stage whose run `run` is, and of every stage it was adopted from, to
    `out/stages/`: what the stage was, and which stages count as one when their cost is added up."""
    root = store_root(run)
    if root is None:
        return
    for identity in stands_for(root, identity_of(run)):
        source = stage_dir(root, identity) / IDENTITY_FILE
        target = stage_dir(out, identity) / IDENTITY_FILE
        if source.is_file() and not target.is_file():
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)


def load_results(roots: list[Path]) -> list[JobResult]:
    """Every finished job's result under the `roots` (runs dirs or archives), each with its `job_dir`. A job found
    more than once (the same sweep and job name) counts once: the result that finished last, else the first
    found. A root inside another is read only as itself."""
    chosen: dict[tuple[str, str], JobResult] = {}
    for root in roots:
        inner = [r for r in roots if Path(root).resolve() in Path(r).resolve().parents]
        for path in _result_files(root, skip=inner):
            if path.name != RESULT:
                continue
            result = read_result(path)
            key = job_key(path.parent)
            if key not in chosen or result.finished > chosen[key].finished:
                chosen[key] = result
    return [chosen[key] for key in sorted(chosen)]


def archived_result(cfg: DictConfig, job_dir: Path, planned: list[PlannedStage]) -> tuple[Path, Change | None] | None:
    """The job's `result.json` in the archive (`cfg.archive`, `mapush archive`), with what makes it other than the
    experiment plans the job now (`planned`): None when it finished as planned, and is done though its runs are on
    another machine or gone. None when the archive holds no result of the job."""
    if not cfg.get("archive"):
        return None
    archive = Path(cfg.archive)
    path = archive.joinpath(*job_key(job_dir), RESULT)
    if not path.is_file():
        return None
    return path, result_changes(read_result(path), cfg, planned, archive)


def result_roots(cfg: DictConfig) -> list[Path]:
    """Where a sweep job's finished results and stages are found: the sweep root, and the archive where one is set."""
    return [Path(cfg.sweep_root), *([Path(cfg.archive)] if cfg.get("archive") else [])]


def job_made_already(
    cfg: DictConfig, job_dir: Path, planned: list[PlannedStage], finished: list[JobResult] | None = None
) -> tuple[JobResult, dict, dict | None] | None:
    """A finished job of another sweep, under the sweep root or in the archive, that made what this job would make:
    its stages the ones this job plans (the same identities), and every evaluation this job asks for made alike
    (the same overrides, locomotion policy, episodes and seeds), with its learning curve where the budget asks for
    one. Returns (that result, the evaluations, the curve) as `still_valid` keeps them for this job, or None. Such
    a job is done already: the scalability study's 1- and 3-robot jobs are the main table's SA and Ours jobs of
    the cylinder. The first such job found in sweep order counts. `finished`: the results under those roots, when
    the caller has read them already (`load_results`)."""
    if finished is None:
        finished = load_results(result_roots(cfg))
    own = job_key(job_dir)
    budget = budget_of(cfg)
    asked = sorted(name for name, spec in cfg.experiment.evals.items() if applies(spec, cfg.method.name))
    alike = {"episodes": int(budget.eval.episodes), "seeds": [int(s) for s in budget.eval.seeds]}
    wanted = {stage.name for stage in planned}
    for result in finished:
        root = Path(result.job_dir).parent.parent
        if job_key(result.job_dir) == own or set(result.stages) != wanted:
            continue
        if same_stages(result, cfg, planned, root) != wanted:
            continue
        evals, curve = still_valid(result, cfg, planned, root)
        if sorted(evals) != asked or any({k: getattr(e, k) for k in alike} != alike for e in evals.values()):
            continue
        if (curve is None) == bool(budget.get("curve")):
            continue
        drawn = result.stage_curves or {}
        if all(drawn_alike(drawn.get(name), spec) for name, spec in stage_curve_specs(cfg, wanted).items()):
            return result, evals, curve
    return None


def made_otherwise_all(results: list[JobResult], memo: Path | None = None) -> None:
    """Set each result's `made_otherwise` (`made_otherwise`). Composing every job's experiment takes about a
    second a job, so what was found of a job is kept in `memo` (a JSON file) under the key of everything it depends
    on: the result's bytes, the store's stage records, the saved config of each of its stage runs that is here (a
    legged evaluation reads which locomotion policy its stage ran with), and every file of the mapush package (its
    configs, code and shipped policies) with the versions of Hydra and OmegaConf. A job keeps up to `MEMO_KEYS`
    findings, so that a machine with its runs and one without (the archive in git) each find theirs."""
    earlier = read_memo(memo)
    kept = {}
    for r, (name, key) in zip(results, memo_keys(results), strict=True):
        entries = memo_entries(earlier.get(name))
        found = next((entry for entry in entries if entry["key"] == key), None)
        change = Change.from_record(found["change"]) if found else made_otherwise(r)
        r.made_otherwise = change
        others = [entry for entry in entries if entry["key"] != key][: MEMO_KEYS - 1]
        kept[name] = [{"key": key, "change": change and dataclasses.asdict(change)}, *others]
    if memo is not None and kept != earlier:
        with contextlib.suppress(OSError):  # a read-only root: checked, not remembered
            write_json(memo, kept)


def memo_keys(results: list[JobResult], runs_here: bool = True) -> list[tuple[str, str]]:
    """Each result's name in the memo (`<sweep>/<job>`) and its key there (`made_otherwise_all`): a hash of all
    that its finding depends on. `runs_here=False`: the key on a machine that holds the archive alone, none of its
    stage runs (a fresh clone), whatever this one holds."""
    package, records, keys = composing_digest(), {}, []
    for r in results:
        store = Path(r.job_dir).parent.parent
        if store not in records:
            records[store] = files_digest(sorted(store.glob(f"{STORE}/*/{IDENTITY_FILE}")), store)
        runs = [saved for path in r.stages.values() if runs_here and (saved := Path(path) / "config.yaml").is_file()]
        parts = [package, records[store], files_digest([Path(r.job_dir) / RESULT], store)]
        parts += [f"{path}\0{hashlib.sha256(path.read_bytes()).hexdigest()}" for path in runs]
        keys.append(("/".join(job_key(r.job_dir)), hashlib.sha256("\n".join(parts).encode()).hexdigest()))
    return keys


def clone_memo(root: Path, made: dict) -> tuple[dict, list[str]]:
    """What a fresh clone finds of the jobs of the results root `root` (the archive) in the memo `made`: for each
    job, the findings kept under the key that a machine without its stage runs computes (`memo_keys`), and the
    names of the jobs with none (where the clone's `mapush tables` would compose them again)."""
    kept, lacking = {}, []
    for name, key in memo_keys(load_results([Path(root)]), runs_here=False):
        kept[name] = [entry for entry in memo_entries(made.get(name)) if entry["key"] == key]
        if not kept[name]:
            lacking.append(name)
    return kept, lacking


def memo_lacks(root: Path) -> tuple[list[str], int]:
    """The jobs whose finding the memo of the archive `root` lacks as a fresh clone looks it up (`clone_memo`), by
    name, and how many jobs the archive holds."""
    kept, lacking = clone_memo(root, read_memo(Path(root) / CHECKED))
    return lacking, len(kept)


MEMO_KEYS = 2
"""Findings kept per job in the memo (`made_otherwise_all`), the newest first: with its runs here and without."""


def memo_entries(found) -> list[dict]:
    """A job's findings in the memo, newest first: a list, or the one mapping memos held before 2026-12-07."""
    entries = found if isinstance(found, list) else [found]
    return [e for e in entries if isinstance(e, dict) and isinstance(e.get("key"), str) and "change" in e]


CHECKED = "jobs_checked.json"
"""The memo in each results root (a runs dir, the archive) of what was found of its archived jobs against their
experiments (`made_otherwise_all`): kept with the results it speaks of, so that any `mapush tables`, into any dir,
finds it again without composing the jobs' configs while nothing they depend on changed."""


def check_results(results: list[JobResult]) -> None:
    """`made_otherwise_all` for the results of each root they were read from (`<root>/<sweep>/<job>/`), with that
    root's memo (`CHECKED`); a root that cannot be written keeps its memo as it was."""
    by_root: dict[Path, list[JobResult]] = {}
    for r in results:
        by_root.setdefault(Path(r.job_dir).parent.parent, []).append(r)
    for root, found in by_root.items():
        made_otherwise_all(found, memo=root / CHECKED)


def read_memo(memo: Path | None) -> dict:
    try:
        return json.loads(Path(memo).read_text()) if memo else {}
    except (OSError, ValueError):
        return {}


def files_digest(paths: list[Path], base: Path) -> str:
    """One hash of the files' names (relative to `base`) and bytes."""
    digest = hashlib.sha256()
    for path in paths:
        digest.update(f"{Path(path).relative_to(base)}\0".encode() + Path(path).read_bytes())
    return digest.hexdigest()


NOT_COMPOSING = ("cli", "api.py", "gym.py", "commands", "report", "bench", "calibration")
"""The parts of the package that take no part in composing a job or planning its stages: the layers above the
experiments' and its independent siblings in the layers contract (pyproject.toml, tests/repo/test_layers.py), which
the experiments never import. A change to them leaves what was found of an archived job as it was."""


@functools.cache
def composing_digest() -> str:
    """One hash of every file of the mapush package that composing a job can read (code, configs, shipped
    policies: all but `NOT_COMPOSING`) and of the versions of the libraries that compose its configs."""
    package = Path(__file__).resolve().parents[1]
    skipped = [package / part for part in NOT_COMPOSING]
    files = sorted(
        p for p in package.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts and not any(p == s or s in p.parents for s in skipped)
    )  # fmt: skip
    return f"hydra {hydra.__version__} omegaconf {omegaconf.__version__} {files_digest(files, package)}"


def made_otherwise(result: JobResult) -> Change | None:
    """What makes a finished `result` other than its experiment plans the job now (another recipe: a budget, a
    reward or tracker value, an evaluation), None when nothing does or when that cannot be told (a result without
    stages in a store, or whose experiment no longer composes). The job is composed from the axes its dir is named
    by (Hydra's `override_dirname`, e.g. `agents=2,method=ours,seed=0,task=cylinder`), its experiment, budget and
    stage overrides; its stages' records are read from the root it lies under (`<root>/<sweep>/<job>/`)."""
    job_dir = Path(result.job_dir)
    if not any(identity_of(Path(path)) for path in result.stages.values()):
        return None
    axes = [axis for axis in job_dir.name.split(",") if "=" in axis]
    extra = [every_stage_override(result.overrides)] if result.overrides else []
    extra += searchpath_overrides(result.overrides)  # the sweep's too: a task of yours
    try:
        cfg = compose_config(
            [f"experiment={result.experiment}", f"budget={result.budget}", *axes, *extra], config_name="sweep"
        )
        return result_changes(result, cfg, planned_stages(cfg), job_dir.parent.parent)
    except (BadInput, KeyError, ValueError):
        return None
