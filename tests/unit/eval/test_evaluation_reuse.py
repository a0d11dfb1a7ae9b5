"""A sweep's job resumed after a cut keeps the evaluations it finished before (`evaluate(..., reuse=True)`): only the
same checkpoint, episodes, seeds and overrides count as the same evaluation."""

from __future__ import annotations

import json

import pytest

from mapush.eval import rollout


def test_a_finished_evaluation_is_kept_and_any_other_is_made_again(run_copy, monkeypatch):
    first = rollout.evaluate(run_copy, 2, [0], ["log.eval_episodes=0"], name="main", reuse=True)
    record = json.loads(first.read_text())
    assert record["overrides"] == ["log.eval_episodes=0"] and record["episodes"] == 2

    def evaluated_again(*args, **kwargs):
        raise AssertionError("evaluated again")

    monkeypatch.setattr(rollout, "_record_episodes", evaluated_again)
    assert rollout.evaluate(run_copy, 2, [0], ["log.eval_episodes=0"], name="main", reuse=True) == first
    for episodes, seeds, overrides, reuse in [
        (3, [0], ["log.eval_episodes=0"], True),  # more episodes
        (2, [1], ["log.eval_episodes=0"], True),  # another seed
        (2, [0], ["log.eval_episodes=0", "rules=strict"], True),  # other overrides
        (2, [0], ["log.eval_episodes=0"], False),  # `mapush eval` always evaluates
    ]:
        with pytest.raises(AssertionError, match="evaluated again"):
            rollout.evaluate(run_copy, episodes, seeds, overrides, name="main", reuse=reuse)
    record["config_sha256"] = "0" * 64  # what an override named held otherwise then (a rule set edited since)
    first.write_text(json.dumps(record))
    with pytest.raises(AssertionError, match="evaluated again"):
        rollout.evaluate(run_copy, 2, [0], ["log.eval_episodes=0"], name="main", reuse=True)
    first.write_text(first.read_text()[:40])  # cut: made again, not read
    with pytest.raises(AssertionError, match="evaluated again"):
        rollout.evaluate(run_copy, 2, [0], ["log.eval_episodes=0"], name="main", reuse=True)
