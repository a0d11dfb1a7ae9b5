"""`mapush plot`: learning curves from the `metrics.mcap` of one or more runs, as a PNG.

Runs whose configs differ only in the seed form one group, drawn as the mean over its runs with a +- std band;
each group is labelled by the overrides it was trained with. Panels: success rate, mean reward, and every reward
term (the mean episode sum logged as `Reward/<term>`), against the PPO iteration.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from omegaconf import OmegaConf

from mapush.atomic import replacing
from mapush.config import load_run_config
from mapush.errors import BadInput
from mapush.logging.mcap_files import is_complete, training_scalars
from mapush.untrusted import load_yaml

FIXED_PANELS = ("Metrics/success_rate", "Train/mean_reward")
IGNORED_OVERRIDES = ("seed=", "train.run_root=", "train.progress=")


def _group_key(cfg) -> str:
    cfg = cfg.copy()
    cfg.pop("seed")
    cfg.train.pop("run_root", None)
    return OmegaConf.to_yaml(cfg)


def _label(run_dir: Path, cfg) -> str:
    path = run_dir / "overrides.yaml"
    overrides = [str(o) for o in load_yaml(path)] if path.is_file() else []
    kept = [o for o in overrides if not o.startswith(IGNORED_OVERRIDES)]
    return " ".join(kept) if kept else f"{cfg.level.name} / {cfg.task.name}"


def group_runs(run_dirs: list[Path]) -> dict[str, list[Path]]:
    """Runs keyed by a label; runs with the same config apart from the seed share one."""
    groups: dict[str, list[Path]] = {}
    labels: dict[str, str] = {}
    for run_dir in run_dirs:
        cfg = load_run_config(run_dir)
        key = _group_key(cfg)
        if key not in labels:
            label = _label(run_dir, cfg)
            labels[key] = label if label not in groups else f"{label} ({len(groups) + 1})"
            groups[labels[key]] = []
        groups[labels[key]].append(run_dir)
    return groups


def _no_scalars(run_dirs: list[Path]) -> str:
    """Why no curve can be drawn: a metrics file cut before its first complete iteration (or empty), or runs that
    logged no iteration."""
    cut = [p for run in run_dirs for p in sorted(Path(run).glob("metrics*.mcap")) if not is_complete(p)]
    if cut:
        return (
            f"{str(cut[0])!r} is cut or empty: it holds no complete iteration (`mapush logs recover {cut[0]} -o FILE` "
            "copies what it holds); valid: a run with a logged iteration"
        )
    return f"no success or reward scalars in {', '.join(map(str, run_dirs))}; valid: runs that logged an iteration"


def mean_std(series: list[dict[int, float]], smooth: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Iterations, mean and std over runs (at the iterations every run has), after a trailing moving average."""
    common = sorted(set.intersection(*(set(s) for s in series)))
    values = np.array([[s[i] for i in common] for s in series], dtype=float)  # (runs, iterations)
    if smooth > 1 and values.shape[1] >= smooth:
        kernel = np.ones(smooth) / smooth
        values = np.stack([np.convolve(row, kernel, mode="valid") for row in values])
        common = common[smooth - 1 :]
    return np.array(common), values.mean(0), values.std(0)


def plot_runs(run_dirs: list[Path], out: Path, smooth: int = 5) -> Path:
    """Draw the learning curves of `run_dirs` into the PNG `out`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if smooth < 1:
        raise BadInput(f"--smooth {smooth} must be a window of 1 or more iterations")
    groups = group_runs(run_dirs)
    scalars = {run: training_scalars(run) for runs in groups.values() for run in runs}
    terms = sorted({tag for s in scalars.values() for tag in s if tag.startswith("Reward/")})
    panels = [tag for tag in FIXED_PANELS if any(tag in s for s in scalars.values())] + terms
    if not panels:
        raise BadInput(_no_scalars(run_dirs))
    cols = min(3, len(panels))
    rows = -(-len(panels) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.8 * cols, 3.3 * rows), squeeze=False)
    short: set[str] = set()
    for ax, tag in zip(axes.flat, panels, strict=False):
        for label, runs in groups.items():
            series = [scalars[r][tag] for r in runs if scalars[r].get(tag)]
            if not series:
                continue
            it, mean, std = mean_std(series, smooth)
            if smooth > 1 and len(it) < smooth:
                short.add(f"{label} has {len(it)} iterations, fewer than --smooth {smooth}: drawn unsmoothed")
            marker = "o" if len(it) < 3 else None  # a line of one or two points would not show
            (line,) = ax.plot(it, mean, label=f"{label} (n={len(series)})", linewidth=1.4, marker=marker)
            if len(series) > 1:
                ax.fill_between(it, mean - std, mean + std, color=line.get_color(), alpha=0.2)
        ax.set_title(tag.split("/", 1)[1].replace("_", " "))
        ax.set_xlabel("iteration")
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(panels) :]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 3), frameon=False)
    fig.tight_layout(rect=(0, 0.04 + 0.03 * ((len(labels) - 1) // 3), 1, 1))
    out.parent.mkdir(parents=True, exist_ok=True)
    for warning in sorted(short):
        print(f"mapush plot: warning: {warning}", file=sys.stderr)
    with replacing(out) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return out
