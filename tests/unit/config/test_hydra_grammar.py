"""Hydra's conventions through the real CLI: `--cfg`, `hydra.run.dir`, `.hydra/` in run dirs, sweep functions."""

from __future__ import annotations

import pytest
import yaml

from mapush.experiments.sweep_axes import job_combos, split_axes


def test_cfg_job_prints_the_composed_config_and_trains_nothing(cli, tmp_path):
    proc = cli("train", "--cfg", "job", "task=tblock", "seed=7")
    assert proc.returncode == 0, proc.stderr
    cfg = yaml.safe_load(proc.stdout)
    assert cfg["task"]["name"] == "tblock" and cfg["seed"] == 7 and "hydra" not in cfg
    assert not (tmp_path / "runs").exists()
    both = yaml.safe_load(cli("train", "--cfg", "all").stdout)
    assert "hydra" in both and both["task"]["name"] == "cuboid"


@pytest.mark.slow
def test_hydra_run_dir_decides_the_run_dir_which_carries_dot_hydra(cli, tmp_path):
    chosen = tmp_path / "my_run"
    proc = cli("train", "debug=smoke", f"hydra.run.dir={chosen}")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == str(chosen)
    assert (chosen / "policy.pt").is_file()
    hydra = chosen / ".hydra"
    assert yaml.safe_load((hydra / "config.yaml").read_text())["train"]["run_dir"] == str(chosen)
    assert yaml.safe_load((hydra / "overrides.yaml").read_text()) == ["debug=smoke", f"hydra.run.dir={chosen}"]
    assert yaml.safe_load((hydra / "hydra.yaml").read_text())["hydra"]["run"]["dir"] == str(chosen)
    again = cli("train", "debug=smoke", f"hydra.run.dir={chosen}")
    assert again.returncode == 2 and "is not empty" in again.stderr


@pytest.mark.parametrize(
    ("override", "values"),
    [
        ("agents=range(1,5)", ["1", "2", "3", "4"]),
        ("task=choice(cuboid,tblock)", ["cuboid", "tblock"]),
        ("task=glob(c*)", ["cuboid", "cylinder"]),
        ("seed=0,1,2", ["0", "1", "2"]),
        ("overrides=['a=1','b=2']", ["['a=1','b=2']"]),
    ],
)
def test_sweep_axes_follow_hydras_sweep_grammar(override, values):
    key = override.partition("=")[0]
    assert split_axes([override]) == {key: values}


def test_jobs_are_the_product_of_the_axes():
    combos = job_combos(["method=choice(ours,sa)", "agents=range(2,4)", "seed=0"])
    assert combos == [
        ["method=ours", "agents=2", "seed=0"],
        ["method=ours", "agents=3", "seed=0"],
        ["method=sa", "agents=2", "seed=0"],
        ["method=sa", "agents=3", "seed=0"],
    ]


def test_a_glob_over_a_key_that_is_not_a_group_is_refused(cli):
    proc = cli("sweep", "seed=glob(*)", "--dry-run")
    assert proc.returncode == 2 and "glob()" in proc.stderr and "valid:" in proc.stderr


@pytest.mark.slow
def test_the_dry_run_expands_hydra_sweep_functions(cli):
    proc = cli("scale", "--agents", "1", "task=glob(cyl*)", "seed=range(0,2)", "--dry-run")
    assert proc.returncode == 0, proc.stderr
    assert "2 jobs, 0 finished; 4 stages to run" in proc.stdout
