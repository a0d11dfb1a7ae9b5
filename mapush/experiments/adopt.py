"""`mapush stages adopt`: put runs trained by hand (`mapush train`) into a sweep's store as the stages they are, so
the sweep reuses them.

A stage is its composed config, budget included (`stages.py`): a run that `mapush train` made with the config a
sweep's stage composes to is that stage, trained already, so a probe that becomes the recipe need not train again.
For every stage the sweep plans that has no run yet, `adopt` looks among the runs for one whose config has the
stage's identity (a frozen `mid` named by path counts as the stage that run was adopted as, so adopt a hierarchy's
mid and high runs together) and copies it into `stages/<identity>/` (weights hard-linked), its `mid` pointed at the
adopted copy, with a `stage.yaml` that says where it came from. Then `mapush sweep` with the same overrides reuses
it and evaluates it as it would a stage it trained.

    mapush stages adopt --run RUN_DIR [--run RUN_DIR ...] experiment=main method=ours task=cuboid,tblock
"""

from __future__ import annotations

from pathlib import Path

from omegaconf import OmegaConf

from mapush.config import load_run_config, to_plain
from mapush.experiments import stages
from mapush.experiments.sweep_axes import planned_jobs, sweep_overrides
from mapush.rundir import find_runs
from mapush.untrusted import load_yaml

RUN_CONFIG = "config.yaml"


def run_identity(run_dir: Path, adopted: dict[Path, Path]) -> str | None:
    """The identity `run_dir` has as a stage; None for a run on a frozen mid run that was not adopted."""
    cfg = to_plain(load_run_config(run_dir))
    if not cfg.get("mid"):
        return stages.identity(cfg, [], {})
    mid = adopted.get(Path(cfg["mid"]).resolve())
    if mid is None:
        return None
    cfg["mid"] = None
    return stages.identity(cfg, ["mid=@mid"], {"mid": stages.identity_of(mid)})


def adopt(runs: list[Path], overrides: list[str]) -> dict[Path, Path]:
    """Copy each of `runs` that is a planned stage without a run into the store: {run: its copy in the store}."""
    adopted: dict[Path, Path] = {}
    for job in planned_jobs(sweep_overrides(overrides)):
        for stage in job.stages:
            directory = stages.stage_dir(Path(job.cfg.sweep_root), stage.identity)
            for run in runs:
                if run in adopted or run_identity(run, adopted) != stage.identity:
                    continue
                held = find_runs(directory)
                if held:  # adopted before, or trained by a sweep: a high run built on it resolves to that run
                    adopted[run] = held[0].resolve()
                    continue
                level, task = stage.cfg["level"]["name"], stage.cfg["task"]["name"]
                target = directory / level / task / run.name
                stages.copy_run(run, target)
                config = load_yaml(run / RUN_CONFIG)
                if config.get("mid"):  # the frozen mid level: the adopted copy of the run it named
                    config.mid = str(adopted[Path(config.mid).resolve()])
                    OmegaConf.save(config, target / RUN_CONFIG)
                stages.write_identity(directory, stage.cfg, stage.identity, trained_as_run=str(run))
                adopted[run] = target.resolve()
                print(f"adopted {run} as {' '.join(job.combo)} {stage.name}: {target}")
    for run in runs:
        if run not in adopted:
            print(f"not adopted (no planned stage without a run has its config): {run}")
    return adopted
