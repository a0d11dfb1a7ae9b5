"""Hostile or damaged files through the real CLI: a cut or altered record, an output path of the wrong kind, a name
or seed out of range is one line on stderr naming it, exit code 2, and nothing written or replaced."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from stand_ins import assert_bad_input

JOB = Path("ocb_ablation_quick") / "method=ours,seed=0"
POINTS = [{"iteration": k, "env_steps": (k + 1) * 1_000_000, "success_rate": 0.5} for k in range(3)]
RESULT = {
    "table": "ocb_ablation",
    "variant": "quick",
    "method": "ours",
    "task": "ocb_cuboid",
    "num_agents": 2,
    "seed": 0,
    "evals": {"t20": {"success_rate": 0.5, "completion_time": 0.8, "completion_time_s": 16.0}},
    "curve": {
        "eval": "t20",
        "every_env_steps": 1e6,
        "reach": 0.5,
        "rule": {"tail": 0.2, "max_gain": 0.03},
        "points": POINTS,
    },
    "format_version": 1,
}


def _altered(path: str, value) -> str:
    """RESULT as JSON with the field at dotted `path` (list items by index) set to `value`."""
    record = json.loads(json.dumps(RESULT))
    *parents, leaf = path.split(".")
    node = record
    for key in parents:
        node = node[int(key)] if isinstance(node, list) else node[key]
    node[int(leaf) if isinstance(node, list) else leaf] = value
    return json.dumps(record)


DAMAGED = {  # result.json's text -> what the line names
    "cut": (json.dumps(RESULT)[:150], "not a readable JSON record"),
    "nan": (json.dumps(RESULT).replace('"success_rate": 0.5, "completion', '"success_rate": NaN, "completion'), "NaN"),
    "infinity": (_altered("evals.t20.completion_time", "@").replace('"@"', "-Infinity"), "Infinity"),
    "overflow": (_altered("evals.t20.completion_time", "@").replace('"@"', "1e999"), "1e999"),
    "string rate": (_altered("evals.t20.success_rate", "0.5"), "evals.t20.success_rate"),
    "evals a list": (_altered("evals", [1, 2]), "field evals is"),
    "curve point": (_altered("curve.points.1.success_rate", None), "curve.points[1].success_rate"),
    "point missing": (_altered("curve.points.2", {"iteration": 3}), "curve.points[2].env_steps is missing"),
    "rule": (_altered("curve.rule", {"tail": 0.2}), "curve.rule.max_gain is missing"),
    "seed": (_altered("seed", 0.5), "field seed"),
    "future version": (_altered("format_version", 99), "format_version 99"),
    "unknown version": (_altered("format_version", "one"), "format_version 'one'"),
    "negative version": (_altered("format_version", -1), "format_version -1"),
    "not a record": ("[1, 2]", "not a record"),
    "not text": ("\udcff", "not text"),
}


@pytest.mark.parametrize("case", list(DAMAGED))
def test_a_damaged_result_is_refused_in_one_line_naming_the_file_and_the_field(tmp_path, case):
    from mapush.errors import BadInput
    from mapush.experiments.archive import load_results

    text, named = DAMAGED[case]
    result = tmp_path / "runs" / JOB / "result.json"
    result.parent.mkdir(parents=True)
    result.write_bytes(text.encode(errors="surrogateescape"))
    with pytest.raises(BadInput) as refused:
        load_results([tmp_path / "runs"])  # what `mapush tables` reads first, from every root
    line = str(refused.value)
    assert "\n" not in line and all(part in line for part in (str(JOB / "result.json"), named, "valid:"))


@pytest.mark.parametrize("case", ["cut", "evals a list"])  # the parse and the schema; every case: the test above
@pytest.mark.parametrize("where", ["runs", "results/jobs"])
def test_tables_over_a_damaged_result_is_one_line_naming_it_and_writes_nothing(cli, tmp_path, snapshot, case, where):
    text, named = DAMAGED[case]
    result = tmp_path / where / JOB / "result.json"
    result.parent.mkdir(parents=True)
    result.write_bytes(text.encode(errors="surrogateescape"))
    out = tmp_path / "out"
    out.mkdir()
    (out / "ocb_ablation_quick.md").write_text("an earlier table\n")
    before = snapshot(tmp_path)
    # "runs" named by --runs; the archive found by default, as on a machine without runs/
    args = ("--runs", tmp_path / where) if where == "runs" else ()
    line = assert_bad_input(cli("tables", *args, "--out", out), "result.json", named, "valid:")
    assert str(JOB / "result.json") in line
    assert snapshot(tmp_path) == before


def test_tables_over_a_sound_result_still_writes_it(cli, tmp_path):
    """The check refuses the damaged only: RESULT as written fills its cells."""
    result = tmp_path / "runs" / JOB / "result.json"
    result.parent.mkdir(parents=True)
    result.write_text(json.dumps(RESULT))
    proc = cli("tables", "--runs", tmp_path / "runs", "--out", tmp_path / "out", "--table", "ocb_ablation")
    assert proc.returncode == 0, proc.stderr
    assert "nan" not in (tmp_path / "out" / "ocb_ablation_quick.md").read_text()


@pytest.fixture
def kinds(tmp_path):
    """`kinds[name]`: a path of each wrong kind under tmp_path/w: a dir, a file, a symlink to a file, one to a dir."""
    root = tmp_path / "w"
    (root / "dir").mkdir(parents=True)
    (root / "file").write_text("kept\n")
    (root / "link").symlink_to(root / "file")
    (root / "dirlink").symlink_to(root / "dir")
    return {name: root / name for name in ("dir", "file", "link", "dirlink")}


@pytest.mark.parametrize(
    ("args", "kind", "named"),
    [
        (("tables", "--out", "{}"), "file", "is a file"),
        (("tables", "--out", "{}"), "dirlink", "is a symlink"),
        (("tables", "--out", "{}/sub"), "file", "is a file, not a dir"),
        (("archive", "--runs", ".", "--out", "{}"), "file", "is a file"),
        (("plot", "nowhere", "-o", "{}"), "dir", "is a directory"),
        (("plot", "nowhere", "-o", "{}"), "link", "is a symlink"),
        (("logs", "recover", "cut.mcap", "-o", "{}"), "dir", "is a directory"),
        (("logs", "recover", "cut.mcap", "-o", "{}"), "link", "is a symlink"),
        (("logs", "layout", "-o", "{}"), "dir", "is a directory"),
        (("compare", "nowhere", "lowlevel=go1", "--out", "{}/OUT"), "dir", "OUT.md' is a directory"),
        (("bench", "--json", "{}"), "dir", "is a directory"),
        (("plan", "--png", "{}"), "dirlink", "is a symlink"),
        (("calibrate", "--out", "{}"), "link", "is a symlink"),
    ],
)
def test_an_output_path_of_the_wrong_kind_is_one_line_and_replaces_nothing(
    cli, tmp_path, snapshot, kinds, args, kind, named
):
    (tmp_path / "cut.mcap").write_bytes(b"\x89MCAP0\r\n")
    (kinds["dir"] / "OUT.md").mkdir()  # compare's OUT.md
    before = snapshot(tmp_path)
    line = assert_bad_input(cli(*(a.format(kinds[kind]) for a in args)), named, "valid:")
    assert str(kinds[kind]) in line
    assert snapshot(tmp_path) == before
    assert (kinds["file"]).read_text() == "kept\n"


def test_tables_refuse_a_dir_where_a_table_file_goes_before_writing_any(cli, tmp_path, snapshot):
    result = tmp_path / "runs" / JOB / "result.json"
    result.parent.mkdir(parents=True)
    result.write_text(json.dumps(RESULT))
    out = tmp_path / "out"
    (out / "ocb_ablation_quick.tex").mkdir(parents=True)
    (out / "main_quick.md").write_text("an earlier table\n")
    before = snapshot(tmp_path)
    proc = cli("tables", "--runs", tmp_path / "runs", "--out", out)
    assert_bad_input(proc, "ocb_ablation_quick.tex", "is a directory")
    assert snapshot(tmp_path) == before


LONG = "a" * 300


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (("train", "debug=smoke", f"task.name={LONG}"), "(1 to 64)"),
        (("eval", "nowhere", "--name", LONG), "1 to 64 letters"),
        (("train", "debug=smoke", "train.run_root={tmp}/" + "r" * 10000), "File name too long"),
        (("train", "debug=smoke", "train.run_dir={tmp}/" + "d" * 300), "File name too long"),
    ],
)
def test_a_name_too_long_for_the_filesystem_is_one_line_and_makes_nothing(cli, tmp_path, snapshot, args, named):
    before = snapshot(tmp_path)
    line = assert_bad_input(cli(*(a.format(tmp=tmp_path) for a in args)), named, "valid:")
    assert len(line) < 600  # the value shown cut short
    assert snapshot(tmp_path) == before and not (tmp_path / "runs").exists()


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (("train", "debug=smoke", "train.run_root=runs", "seed=18446744073709551616"), "seed=18446744073709551616"),
        (("train", "debug=smoke", "train.run_root=runs", "seed=4294967296"), "seed=4294967296"),
        (("eval", "nowhere", "--seeds", "0,4294967296"), "--seeds '0,4294967296'"),
        (("compare", "nowhere", "lowlevel=go1", "--seeds", "4294967296"), "--seeds '4294967296'"),
        (("play", "nowhere", "--seed", "4294967296"), "--seed 4294967296"),
    ],
)
def test_a_seed_numpy_cannot_take_is_one_line_before_any_run_dir(cli, tmp_path, args, named):
    assert_bad_input(cli(*args), named, "4294967295]")
    assert not (tmp_path / "runs").exists()


def test_an_evaluation_seed_numpy_cannot_take_is_one_line_and_writes_nothing(cli, run_copy, snapshot):
    before = snapshot(run_copy)
    assert_bad_input(cli("eval", run_copy, "eval.seeds=[4294967296]"), "eval.seeds=4294967296", "4294967295]")
    assert snapshot(run_copy) == before


def test_a_cut_meta_json_is_one_line_on_resume_and_changes_nothing(cli, run_copy, snapshot):
    meta = run_copy / "meta.json"
    meta.write_text(meta.read_text()[:40])
    before = snapshot(run_copy)
    assert_bad_input(cli("train", "--resume", run_copy, "train.iterations=6"), "meta.json", "cut or altered")
    after = snapshot(run_copy)
    assert {k: v for k, v in after.items() if k != ".busy.lock"} == {
        k: v for k, v in before.items() if k != ".busy.lock"
    }
