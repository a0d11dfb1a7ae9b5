"""mapush as a real package: a wheel installed into a fresh venv trains and evaluates from any directory."""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest
from paths import REPO

from mapush.provenance import files_hash

ROOT = REPO


@pytest.mark.slow
def test_a_wheel_in_a_fresh_venv_trains_and_evaluates_from_another_directory(tmp_path):
    source = tmp_path / "source"  # a copy: building writes build/ and *.egg-info into the tree it builds
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, check=True, capture_output=True, text=True).stdout.split()
    for name in files:
        if (ROOT / name).is_file():
            (source / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, source / name)
    dist = tmp_path / "dist"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", dist, source],
        check=True,
        cwd=tmp_path,
    )
    wheel = next(dist.glob("mapush-*.whl"))
    with zipfile.ZipFile(wheel) as packed:  # every shipped locomotion policy, the default's and go1_strong's
        names = set(packed.namelist())
    assert {f"mapush/lowlevel/pretrained/{n}/policy.pt" for n in ("go1", "go1_strong")} <= names
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", venv], check=True)
    python = venv / "bin" / "python"
    target = subprocess.run(
        [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True, capture_output=True, text=True,
    ).stdout.strip()  # fmt: skip
    # the dependencies come from this venv's site-packages (no index here); mapush itself only from the wheel
    (Path(target) / "deps.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    subprocess.run([python, "-m", "pip", "install", "-q", "--no-deps", wheel], check=True)
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("MAPUSH_CONF_DIR", "PYTHONPATH")}  # the wheel alone
    env |= {"OMP_NUM_THREADS": "1"}
    where = subprocess.run(
        [python, "-c", "import mapush.config as c; print(c.CONF_DIR)"], cwd=work, env=env,
        check=True, capture_output=True, text=True,
    ).stdout.strip()  # fmt: skip
    assert where.startswith(target), where  # the installed package's own configs, not the checkout's
    mapush = venv / "bin" / "mapush"
    trained = subprocess.run([mapush, "train", "debug=smoke"], cwd=work, env=env, capture_output=True, text=True)
    assert trained.returncode == 0, trained.stderr
    run_dir = Path(trained.stdout.strip().splitlines()[-1])
    assert (work / run_dir / "policy.onnx").is_file()
    evaluated = subprocess.run(
        [mapush, "eval", run_dir, "--episodes", "2", "--seeds", "0"], cwd=work, env=env, capture_output=True, text=True
    )
    assert evaluated.returncode == 0, evaluated.stderr
    assert "package hash" not in evaluated.stderr  # made and evaluated by the same installed code
    # no git here (commit: null), so the version and the hash of the installed files name the code
    installed = subprocess.run(
        [python, "-c", "from mapush.provenance import provenance as p; import json; print(json.dumps(p()))"],
        cwd=work, env=env, check=True, capture_output=True, text=True,
    ).stdout  # fmt: skip
    expected = json.loads(installed)
    assert expected["mapush_version"] == tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert expected["package_hash"] == files_hash(source / "mapush")  # as the tree it was built from hashes
    for made in ("meta.json", "eval.json"):
        record = json.loads((work / run_dir / made).read_text())
        assert {k: record[k] for k in expected} == expected, made
