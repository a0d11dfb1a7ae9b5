"""Checkpoint retention (`algo.keep_checkpoints`): a run keeps its newest checkpoints and its best one.

The best is the one written at the highest training success, `Metrics/recent_success_rate` (the last 500 training
episodes; one iteration's few episodes would make it a lucky draw), which each checkpoint stores in its `infos`.
A checkpoint without a score (an older run's, or one written before any episode ended) is never the best; of equal
scores the newer is. The newest checkpoint is always kept, so resuming and evaluating a run are unaffected.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

from mapush.rl.policy import read_checkpoint
from mapush.rundir import checkpoint_iteration, checkpoints

SUCCESS_TAG = "Metrics/recent_success_rate"
"""The logged scalar that ranks checkpoints."""
SCORE_KEY = "recent_success_rate"
"""Its key in a checkpoint's `infos`."""


def to_prune(found: list[Path], keep: int, score: Callable[[Path], float]) -> list[Path]:
    """The checkpoints of `found` (oldest first) that are neither among the newest `keep` nor the best by
    `score(path) -> float`; none when `keep` is 0 (keep all)."""
    if keep <= 0 or len(found) <= keep:
        return []
    best = max(found, key=lambda p: (score(p), checkpoint_iteration(p)))
    return [p for p in found[:-keep] if p != best]


def stored_score(path: Path) -> float:
    """The training success a checkpoint was written at; -inf for none or an unreadable file."""
    try:
        infos = read_checkpoint(path).get("infos") or {}
    except Exception:  # a foreign file named like a checkpoint
        return -math.inf
    return _finite(infos.get(SCORE_KEY))


class Retention:
    """Prunes a run dir's checkpoints after each save, remembering the scores it has seen.

    Args:
        keep: newest checkpoints kept besides the best; 0 keeps all.
    """

    def __init__(self, keep: int):
        self.keep = keep
        self._scores: dict[str, float] = {}

    def saved(self, path: Path, score: float | None) -> list[Path]:
        """Record the checkpoint just written at `path` with its `score`, then delete what is not kept; returns
        the deleted checkpoints. The checkpoint at `path` itself is never deleted."""
        path = Path(path)
        self._scores[path.name] = _finite(score)
        pruned = [p for p in to_prune(checkpoints(path.parent), self.keep, self._score) if p != path]
        for old in pruned:
            old.unlink(missing_ok=True)
            self._scores.pop(old.name, None)
        return pruned

    def _score(self, path: Path) -> float:
        if path.name not in self._scores:  # written before this process (a resumed run): read once
            self._scores[path.name] = stored_score(path)
        return self._scores[path.name]


def _finite(value: float | None) -> float:
    return float(value) if value is not None and math.isfinite(float(value)) else -math.inf
