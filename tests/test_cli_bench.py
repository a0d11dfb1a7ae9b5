"""`mapush bench debug=smoke`: it runs and reports its figures (the figures themselves are never asserted)."""

from __future__ import annotations

import json


def test_bench_writes_its_figures_as_json_and_no_run_dir(cli, tmp_path):
    out = tmp_path / "bench.json"
    proc = cli("bench", "debug=smoke", "--json", out)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(out.read_text())
    assert json.loads(proc.stdout) == result
    # smoke: 8 envs x 2 agents on the cuboid, 5 timed steps
    assert (result["task"], result["num_envs"], result["num_agents"], result["steps"]) == ("cuboid", 8, 2, 5)
    for key in ("env_steps_per_s", "raw_sim_steps_per_s", "train_steps_per_s", "peak_rss_mb"):
        assert result[key] > 0
    assert not (tmp_path / "runs").exists()
