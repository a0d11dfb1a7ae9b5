"""Stages trained once: a stage is identified by its composed config, and every sweep under one `sweep_root`
shares one store of finished stages.

The identity of a stage is a hash of its composed, resolved config (budget included, as `train.iterations`),
less what says where it is written, how it is logged or evaluated, how many threads ran it, and how often it
writes checkpoints and how many it keeps (`IGNORED`; sweeps keep them all, for the learning curves), and less the
keys added since at their neutral default (`migrations.UNSET_LATER_KEYS`) and less the reward terms at weight 0
(the reward manager drops them, so a task that switches a new term off keeps the stages trained before it); a frozen
stage it builds on (`mid=@mid`) enters by that stage's identity, not by its path. Two jobs, of one sweep or of
two experiments, whose stages compose alike use one run: `<sweep_root>/stages/<identity>/`. Any change to the
config (a reward weight, the tracker's calibration, the budget) is another identity, so another run.
"""

from __future__ import annotations

import contextlib
import copy
import fcntl
import functools
import hashlib
import json
import os
import shutil
import statistics
from pathlib import Path

from omegaconf import OmegaConf

from mapush.atomic import write_yaml
from mapush.config import compose_config, env_steps_per_iteration, load_run_config, sim_threads, to_plain
from mapush.logging.mcap_files import CPU_TAG, THREADS_TAG, training_scalars
from mapush.migrations import UNSET_LATER_KEYS, stamp, upgrade
from mapush.rundir import POLICY_FILE, checkpoint_iteration, checkpoints, find_runs
from mapush.untrusted import read_yaml

STORE = "stages"
"""The store's folder under `sweep_root`."""
IGNORED = (
    "train.run_root",
    "train.run_dir",
    "train.progress",
    "train.rollout_threads",
    "train.update_threads",
    "algo.keep_checkpoints",
    "algo.save_interval",
    "sim.nthread",
    "device",
    "log",
    "eval",
    "bench",
)
"""Config keys that change where and how a stage runs, not what it learns."""
STAGE_REF = "@"
"""An override value `@STAGE` (e.g. `mid=@mid`) stands for that earlier stage's run dir."""
IDENTITY_FILE = "stage.yaml"
ITERATION_TIMES = ("Perf/collection_time", "Perf/learning_time")
"""The training scalars whose sum is one PPO iteration's wall time."""
PAUSED_FACTOR = 20.0
"""An iteration this many times longer than its stage's median was paused, not trained (`stage_core_seconds`)."""


def compose_stage(overrides: list[str], iterations_of) -> dict:
    """The stage's composed config (plain) with its budget: `iterations_of(cfg)` becomes `train.iterations`.

    Overrides that refer to an earlier stage (`key=@stage`) are left out here; `identity` adds them.
    """
    cfg = compose_config([o for o in overrides if not is_ref(o)])
    OmegaConf.update(cfg, "train.iterations", iterations_of(cfg))
    return to_plain(cfg)


def identity(cfg: dict, overrides: list[str], identities: dict[str, str]) -> str:
    """The stage's identity: a hash of `cfg` less `IGNORED`, `UNSET_LATER_KEYS` at their default and reward terms
    at weight 0, with `key=@stage` set to that stage's identity."""
    view = OmegaConf.create(cfg)
    terms = OmegaConf.select(view, "reward.terms") or {}
    for name in [name for name, term in terms.items() if term is not None and term.get("weight") == 0]:
        terms.pop(name)
    dropped = [(key, None) for key in IGNORED] + [(key, (default,)) for key, default in UNSET_LATER_KEYS.items()]
    for key, only_at in dropped:  # only_at: None drops the key whatever its value, else only at that one value
        parent, _, leaf = key.rpartition(".")
        node = OmegaConf.select(view, parent) if parent else view
        if node is not None and leaf in node and (only_at is None or node[leaf] == only_at[0]):
            node.pop(leaf)
            if only_at is not None and not node and parent:  # a dict that held only the later key
                grand, _, name = parent.rpartition(".")
                (OmegaConf.select(view, grand) if grand else view).pop(name)
    for override in filter(is_ref, overrides):
        key, _, value = override.partition("=")
        OmegaConf.update(view, key, f"stage:{identities[value[len(STAGE_REF) :]]}", force_add=True)
    text = json.dumps(OmegaConf.to_container(view), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def shorter_twin(sweep_root: Path, cfg: dict, overrides: list[str], identities: dict[str, str]) -> Path | None:
    """The finished run of the longest stage in the store that is this stage (`cfg`, `overrides` and the earlier
    stages' `identities`, as `identity` takes them) but for fewer iterations: lengthening a budget trains such a
    stage on from its end rather than from scratch. PPO here keeps no schedule over the planned iterations (its
    learning rate follows the KL), so a stage trained on is one trained longer, as a cut run resumed is the run."""
    want, iterations = _identity_less_budget(cfg, overrides, identities), int(cfg["train"]["iterations"])
    refs = [(o.partition("=")[0], o.partition("=")[2][len(STAGE_REF) :]) for o in overrides if is_ref(o)]
    found: tuple[int, Path] | None = None
    for record in sorted((Path(sweep_root) / STORE).glob(f"*/{IDENTITY_FILE}")):
        other = stage_record(record).get("config")
        if not other or shape(other) != shape(cfg) or not int(other["train"]["iterations"]) < iterations:
            continue
        paths = {name: OmegaConf.select(OmegaConf.create(other), key) for key, name in refs}
        if any(not path or identity_of(Path(path)) is None for path in paths.values()):
            continue  # a stage that built on a run outside a store: not comparable
        theirs = {name: identity_of(Path(path)) for name, path in paths.items()}
        run = next((r for r in find_runs(record.parent) if (r / POLICY_FILE).is_file()), None)
        if run is None or _identity_less_budget(other, overrides, theirs) != want:
            continue
        if found is None or int(other["train"]["iterations"]) > found[0]:
            found = (int(other["train"]["iterations"]), run)
    return None if found is None else found[1]


def _identity_less_budget(cfg: dict, overrides: list[str], identities: dict[str, str]) -> str:
    """`identity` with `train.iterations` left out: alike for two stages that differ only in how long they learn."""
    view = copy.deepcopy(cfg)
    view["train"].pop("iterations")
    return identity(view, overrides, identities)


def stage_dir(sweep_root: Path, key: str) -> Path:
    """Where the run of stage `key` lives (its run dir is below, as `mapush train` names it)."""
    return Path(sweep_root) / STORE / key


def store_parts(run_dir: Path) -> tuple[str, ...] | None:
    """A stage run's path from the store's folder on, `("stages", identity, level, subject, run)`; None for a run
    outside a store."""
    parts = Path(run_dir).parts
    if STORE not in parts[:-1]:
        return None
    return parts[len(parts) - 1 - parts[::-1].index(STORE) :]


def store_root(run_dir: Path) -> Path | None:
    """The sweep root whose store holds the stage run `run_dir`; None for a run outside a store."""
    parts = store_parts(run_dir)
    return Path(*Path(run_dir).parts[: len(Path(run_dir).parts) - len(parts)]) if parts else None


def identity_of(run_dir: Path) -> str | None:
    """The identity of the stage whose run `run_dir` is (the store dir it lies in); None outside a store."""
    parts = store_parts(run_dir)
    return parts[1] if parts else None


def stands_for(sweep_root: Path, key: str) -> list[str]:
    """The identities stage `key` stands for: its own, then those of the stages it was adopted from, the one first
    trained last (`mapush stages rekey`: the same runs under a config that changed only its form)."""
    found: list[str] = []
    while key and key not in found:
        found.append(key)
        key = _adopted_identity(stage_dir(sweep_root, key) / IDENTITY_FILE)
    return found


def _adopted_identity(record: Path) -> str | None:
    """The identity the stage of `record` (its `stage.yaml`) was adopted from; None for one trained as it is, or no
    record. A record whose text never says `adopted_from` is not parsed: a table asks of hundreds, thousands of
    times."""
    if not Path(record).is_file():
        return None
    found = os.stat(record)
    return _adopted_of(os.path.abspath(record), found.st_size, found.st_mtime_ns)


@functools.lru_cache(maxsize=4096)
def _adopted_of(path: str, size: int, mtime_ns: int) -> str | None:
    if b"adopted_from" not in Path(path).read_bytes():
        return None
    return (_parsed_record(path, size, mtime_ns).get("adopted_from") or {}).get("identity")


def trained_iterations(directory: Path) -> int | None:
    """Iterations the stage in `directory` has trained so far (its newest checkpoint); None once it is finished."""
    for run_dir in find_runs(Path(directory)):
        if (run_dir / POLICY_FILE).is_file():
            return None
        found = checkpoints(run_dir)
        if found:
            return checkpoint_iteration(found[-1]) + 1
    return 0


def shape(cfg: dict) -> tuple:
    """What a stage's training time per env-step depends on: level, object, robots, envs and low level (not the
    seed, a reward weight or the budget). Stages of one shape cost alike per env-step (`cost_per_env_step`)."""
    return (cfg["level"]["name"], cfg["task"]["name"], int(cfg["task"]["num_agents"]), int(cfg["num_envs"]),
            cfg["lowlevel"]["name"])  # fmt: skip


def cost_per_env_step(results: list, roots: list[Path]) -> dict[tuple, tuple[float, float]]:
    """Measured training core-seconds per env-step of each stage `shape`, the lowest and the highest of the
    distinct stages behind `results` (their `stage_core_s`) whose `stage.yaml` lies in the store of one of the
    `roots` (sweep roots or archives): what `mapush sweep --dry-run` estimates the stages it will train from. Stages
    of one shape measured on other days differ by up to four times (the main table's Ours cylinder mid levels: 1113
    core-s on 2026-12-04, 4334 on 2026-12-07, while the code of 2026-12-04 and of 2026-12-07 took 1.95 and 1.87
    CPU-s per SA cuboid mid-level iteration side by side): the machine, and what ran beside it, count in a
    core-second. So an estimate is a range."""
    rates: dict[tuple, list[float]] = {}
    seen: set[str] = set()
    for result in results:
        for name, path in result.stages.items():
            key, core_s = identity_of(Path(path)), result.stage_core_s.get(name)
            if core_s is None or key is None or key in seen:
                continue
            seen.add(key)
            record = next((r for r in (stage_dir(root, key) / IDENTITY_FILE for root in roots) if r.is_file()), None)
            cfg = read_identity(record).get("config") if record else None
            steps = cfg and int(cfg["train"]["iterations"]) * env_steps_per_iteration(cfg)
            if steps:
                rates.setdefault(shape(cfg), []).append(float(core_s) / steps)
    return {kind: (min(found), max(found)) for kind, found in rates.items()}


def write_identity(directory: Path, cfg: dict, key: str, **origin) -> None:
    """Record what the stage is (`stage.yaml`: the identity and the composed config) beside its run; `origin`: where
    a run made elsewhere came from (`adopted_from`, `trained_as_run`, `lengthened_from`)."""
    Path(directory).mkdir(parents=True, exist_ok=True)
    write_yaml(Path(directory) / IDENTITY_FILE, stamp({"identity": key, "config": cfg, **origin}))


def read_identity(record: Path) -> dict:
    """A stage's `stage.yaml` (`write_identity`) as today's form, plain (a copy the caller may change)."""
    return copy.deepcopy(stage_record(record))


def stage_record(record: Path) -> dict:
    """`read_identity`, shared (read it, do not change it): a table reads each of hundreds of records many times,
    so each is parsed once while its file stays as it is (its path, size and modification time)."""
    found = os.stat(record)
    return _parsed_record(os.path.abspath(record), found.st_size, found.st_mtime_ns)


@functools.lru_cache(maxsize=4096)
def _parsed_record(path: str, _size: int, _mtime_ns: int) -> dict:
    return upgrade(read_yaml(path), path)


def copy_run(run_dir: Path, target: Path, leave: tuple[str, ...] = ()) -> None:
    """Copy run `run_dir` to `target` in a store (`_link_weights`), less the files named in `leave`."""
    shutil.copytree(run_dir, target, ignore=shutil.ignore_patterns(*leave), copy_function=_link_weights)


def _link_weights(source: str, destination: str) -> None:
    """A `copytree` copy function for runs: weights hard-linked (written once), everything else copied (a resumed
    run appends to its logs)."""
    (os.link if source.endswith((".pt", ".onnx")) else shutil.copy2)(source, destination)


@contextlib.contextmanager
def held(directory: Path):
    """Hold the stage's lock: a second job needing the same stage waits, then finds it finished."""
    Path(directory).mkdir(parents=True, exist_ok=True)
    with open(Path(directory) / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def is_ref(override: str) -> bool:
    """Whether `override` names an earlier stage of the job (`mid=@mid`), not a value."""
    return override.partition("=")[2].startswith(STAGE_REF)


def stage_core_seconds(run_dir: Path) -> float:
    """Core-seconds of one stage's training (`metrics.mcap`, each iteration once): the CPU seconds an iteration
    recorded (`Perf/cpu_s`, since 2026-11-27), else its wall time as rsl-rl measures it times its MuJoCo threads,
    those the iteration recorded (`Perf/threads`; a run resumed on another machine changes them) or its config's.
    Wall time counts a crowded machine's waits as work; CPU time does not. Of wall times, one longer than
    `PAUSED_FACTOR` times the stage's median stood still (its process stopped, e.g. `kill -STOP` while something
    else ran) and counts as a median one."""
    scalars = training_scalars(run_dir, prefix="Perf/")
    per_iteration: dict[int, float] = {}
    for tag in ITERATION_TIMES:
        for iteration, value in scalars.get(tag, {}).items():
            per_iteration[iteration] = per_iteration.get(iteration, 0.0) + value
    typical = statistics.median(per_iteration.values()) if per_iteration else 0.0
    recorded, configured, cpu = scalars.get(THREADS_TAG, {}), run_threads(run_dir), scalars.get(CPU_TAG, {})
    return sum(
        cpu[it] if it in cpu else (t if t <= PAUSED_FACTOR * typical else typical) * recorded.get(it, configured)
        for it, t in per_iteration.items()
    )


def run_threads(run_dir: Path) -> int:
    """The cores a run's physics used: `sim.nthread`, where 0 means every core of this machine."""
    return sim_threads(load_run_config(run_dir))


def stage_paths(runs: dict[str, str], job_dir: str | Path = "") -> list[Path]:
    """The run dirs of a job's stages (`runs`: stage name -> run dir as its result names it), in training order. A
    stage run that is not where the result says (a path relative to the directory the sweep ran in,
    `runs/sweeps/stages/...`, or a job archived by `mapush archive`) is looked up under the sweep root of the
    job's dir `job_dir`."""
    paths = []
    for text in runs.values():
        path, in_store = Path(text), store_parts(Path(text))
        if not path.is_dir() and in_store and job_dir:
            path = Path(job_dir).parents[1].joinpath(*in_store)
        paths.append(path)
    return paths
