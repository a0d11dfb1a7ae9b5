"""MCAP logs: metrics and episode round trips, Foxglove schema validity, crash safety, summary, recover, layout."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import jsonschema
import numpy as np
import pytest
import torch
from conftest import MAPUSH, composed
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from google.protobuf import descriptor_pb2
from mcap.reader import make_reader
from paths import REPO

from mapush.envs.mid import MidPushEnv
from mapush.levels import scene_layout
from mapush.logging.episodes import EpisodeRecorder
from mapush.logging.foxglove_scene import SceneLayout
from mapush.logging.layout import episode_layout
from mapush.logging.mcap_files import summary
from mapush.logging.metrics import McapLogWriter
from mapush.rewards.manager import RewardManager

REPO = REPO
FOXGLOVE_TYPES = {"foxglove.SceneUpdate": SceneUpdate, "foxglove.FrameTransforms": FrameTransforms, "foxglove.Log": Log}


def read_messages(path: Path) -> list[tuple[str, str, object]]:
    """(topic, schema name, decoded message) of every message, through the indexed reader (as Foxglove reads)."""
    out = []
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
            if schema.name in FOXGLOVE_TYPES:
                decoded = FOXGLOVE_TYPES[schema.name].FromString(message.data)
            else:
                decoded = json.loads(message.data)
            out.append((channel.topic, schema.name, decoded))
    return out


def by_topic(messages) -> dict[str, list]:
    topics: dict[str, list] = {}
    for topic, _, decoded in messages:
        topics.setdefault(topic, []).append(decoded)
    return topics


def record_episode(cfg: dict, path: Path, actions: torch.Tensor, steps: int) -> MidPushEnv:
    """Run 2 envs for `steps` steps with fixed actions, recording env 0's first episode."""
    env = MidPushEnv(cfg, num_envs=2)
    recorder = EpisodeRecorder(path, SceneLayout.from_config(cfg), list(env.rewards.terms), env.exception_names)
    recorder.watch([0], env.dt, "test", from_start=True)
    env.recorders.append(recorder)
    for _ in range(steps):
        env.step(actions)
    recorder.close()
    return env


# ---------------------------------------------------------------------------------------------------------------
# metrics.mcap


def test_metrics_round_trip(tmp_path):
    (tmp_path / "meta.json").write_text(json.dumps({"commit": "abc123", "dirty": False}))
    (tmp_path / "config.yaml").write_text("seed: 0\n")
    writer = McapLogWriter(str(tmp_path), rows_per_env=2, progress=False)
    for it in range(3):
        writer.add_scalar("Metrics/success_rate", 0.1 * it, it)
        writer.add_scalar("Loss/learning_rate", torch.tensor(1e-3), it)  # rsl-rl passes 0-d tensors too
        writer.add_scalar("Perf/total_fps", 1000.0, it)
        writer.end_iteration(it)
    writer.stop()

    with open(tmp_path / "metrics.mcap", "rb") as f:
        reader = make_reader(f)
        got = {}
        for schema, channel, message in reader.iter_messages():
            assert schema.name == "mapush.Scalar"
            got.setdefault(channel.topic, []).append(json.loads(message.data))
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        attachments = {a.name: a.data for a in reader.iter_attachments()}
    assert set(got) == {
        "/metrics/Metrics/success_rate",
        "/metrics/Loss/learning_rate",
        "/metrics/Perf/total_fps",
        "/metrics/Perf/env_steps_per_s",
    }
    assert [m["iteration"] for m in got["/metrics/Metrics/success_rate"]] == [0, 1, 2]
    assert [m["value"] for m in got["/metrics/Metrics/success_rate"]] == pytest.approx([0.0, 0.1, 0.2])
    assert got["/metrics/Loss/learning_rate"][0]["value"] == pytest.approx(1e-3)
    assert got["/metrics/Perf/env_steps_per_s"][0]["value"] == 500.0  # 1000 agent rows/s over 2 agents
    assert metadata["run"]["commit"] == "abc123"
    assert attachments["config.yaml"] == b"seed: 0\n"


def test_metrics_of_a_real_run_hold_every_required_series(smoke_run):
    topics = summary(smoke_run / "metrics.mcap")["topics"]
    terms = RewardManager(json.loads(json.dumps(_run_cfg(smoke_run)["reward"]["terms"]))).terms
    required = [f"/metrics/Reward/{t}" for t in terms] + [
        "/metrics/Metrics/success_rate",
        "/metrics/Train/mean_episode_length",
        "/metrics/Loss/value",
        "/metrics/Loss/surrogate",
        "/metrics/Loss/learning_rate",
        "/metrics/Policy/mean_std",
        "/metrics/Perf/env_steps_per_s",
        "/metrics/Perf/threads",
    ]
    missing = [t for t in required if t not in topics]
    assert not missing
    assert topics["/metrics/Loss/learning_rate"]["messages"] == 2  # one per iteration
    info = summary(smoke_run / "metrics.mcap")
    assert info["complete"]
    assert {"config.yaml", "meta.json"} <= set(info["attachments"])


def _run_cfg(run_dir: Path) -> dict:
    from mapush.config import load_run_config, to_plain

    return to_plain(load_run_config(run_dir))


# ---------------------------------------------------------------------------------------------------------------
# episode files


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A cylinder episode with 3 robots, 0.4 s (20 steps), with known commands."""
    cfg = composed("task=cylinder", "task.num_agents=3", "level.episode_length_s=0.4")
    actions = torch.tensor([[0.2, -0.4, 0.6], [1.0, 0.0, -1.0], [-0.5, 0.5, 0.0]]).expand(2, 3, 3)
    path = tmp_path_factory.mktemp("episodes") / "episodes.mcap"
    env = record_episode(cfg, path, actions, steps=25)
    return path, env, actions


def test_episode_round_trip(recorded):
    path, env, actions = recorded
    messages = read_messages(path)
    schemas = {topic: schema for topic, schema, _ in messages}
    assert schemas == {
        "/scene": "foxglove.SceneUpdate",
        "/tf": "foxglove.FrameTransforms",
        "/commands": "mapush.RobotCommands",
        "/rewards": "mapush.RewardTerms",
        "/log": "foxglove.Log",
        "/episode": "mapush.EpisodeEnd",
    }
    topics = by_topic(messages)
    assert [len(topics[t]) for t in ("/scene", "/tf", "/commands", "/rewards")] == [20] * 4  # 0.4 s at 50 Hz
    assert len(topics["/log"]) == len(topics["/episode"]) == 1
    expected = (actions[0] * env.action_scale).tolist()  # (robot, [vx, vy, yaw rate])
    first = topics["/commands"][0]
    got = [[first["vx"][i], first["vy"][i], first["yaw_rate"][i]] for i in range(3)]
    assert torch.allclose(torch.tensor(got), torch.tensor(expected))
    assert set(topics["/rewards"][0]) == {"total", *env.rewards.terms}
    assert all(len(v) == 3 for v in topics["/rewards"][0].values())
    end = topics["/episode"][0]
    assert end["outcome"] in {"success", "exception", "timeout"}
    assert end["time_s"] == pytest.approx(0.4) or end["outcome"] != "timeout"
    assert end["return"] == pytest.approx(
        [sum(r["total"][i] for r in topics["/rewards"]) for i in range(3)], rel=1e-5, abs=1e-5
    )
    assert end["outcome"] in topics["/log"][0].message


def _proto_fields(file_set: descriptor_pb2.FileDescriptorSet) -> dict:
    """{message full name: {field name: (number, type, label, type name)}} of every message in a descriptor set."""
    out = {}
    for file in file_set.file:
        for message in file.message_type:
            name = f"{file.package}.{message.name}"
            out[name] = {f.name: (f.number, f.type, f.label, f.type_name) for f in message.field}
    return out


def _official_fields(message_class) -> dict:
    file_set = descriptor_pb2.FileDescriptorSet()
    seen, todo = set(), [message_class.DESCRIPTOR.file]
    while todo:
        fd = todo.pop()
        if fd.name in seen:
            continue
        seen.add(fd.name)
        proto = file_set.file.add()
        fd.CopyToProto(proto)
        todo.extend(fd.dependencies)
    return _proto_fields(file_set)


def test_foxglove_messages_are_valid_against_foxglove_schemas(recorded):
    """Each embedded schema matches Foxglove's published definition; each message parses and makes sense."""
    path = recorded[0]
    frames = {"world", "object", "robot0", "robot1", "robot2"}
    with open(path, "rb") as f:
        reader = make_reader(f)
        for schema in reader.get_summary().schemas.values():
            if schema.name.startswith("foxglove."):
                embedded = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
                official = _official_fields(FOXGLOVE_TYPES[schema.name])
                for name, fields in _proto_fields(embedded).items():
                    assert fields == official[name], name
            else:
                json_schema = json.loads(schema.data)
                jsonschema.Draft202012Validator.check_schema(json_schema)
        for schema, _, message in reader.iter_messages():
            if not schema.name.startswith("foxglove."):
                jsonschema.validate(json.loads(message.data), json.loads(schema.data))
                continue
            decoded = FOXGLOVE_TYPES[schema.name].FromString(message.data)
            assert decoded.SerializeToString() == message.data  # nothing unknown to the official definition
            if schema.name == "foxglove.SceneUpdate":
                ids = [e.id for e in decoded.entities]
                assert {"arena", "object", "subgoal", "robot0", "robot1", "robot2"} <= set(ids)
                for entity in decoded.entities:
                    assert entity.frame_id in frames
                    primitives = [*entity.cubes, *entity.cylinders, *entity.arrows]
                    assert primitives
                    for p in primitives:
                        q = p.pose.orientation
                        assert math.isclose(q.x**2 + q.y**2 + q.z**2 + q.w**2, 1.0, rel_tol=1e-6)
                        assert 0 < p.color.a <= 1
                    for p in [*entity.cubes, *entity.cylinders]:
                        assert min(p.size.x, p.size.y, p.size.z) > 0
            elif schema.name == "foxglove.FrameTransforms":
                assert {t.child_frame_id for t in decoded.transforms} == frames - {"world"}
                assert {t.parent_frame_id for t in decoded.transforms} == {"world"}
            else:
                assert decoded.level in (Log.INFO, Log.WARNING)


def test_scene_draws_the_object_in_its_true_shape(recorded):
    path, env, _ = recorded
    scene = by_topic(read_messages(path))["/scene"][0]
    obj = next(e for e in scene.entities if e.id == "object")
    (cylinder,) = obj.cylinders  # the cylinder task: radius 1.2 m (paper), one part
    radius, height = env.cfg["task"]["object"]["parts"][0]["size"]
    assert (cylinder.size.x, cylinder.size.z) == pytest.approx((2 * radius, height))


def test_transforms_and_markers_follow_the_simulation(tmp_path, cfg_for):
    cfg = cfg_for("debug=smoke")
    env = MidPushEnv(cfg, num_envs=2)
    recorder = EpisodeRecorder(
        tmp_path / "e.mcap", SceneLayout.from_config(cfg), list(env.rewards.terms), env.exception_names
    )
    recorder.watch([0], env.dt, "test", from_start=True)
    env.recorders.append(recorder)
    actions = torch.tensor([1.0, 0.0, 0.5]).expand(2, 2, 3)
    env.step(actions)
    state = env.state
    robot_xy, robot_yaw, object_xy = state.robot_xy[0].clone(), state.robot_yaw[0].clone(), state.object_xy[0].clone()
    subgoal = env.subgoal_xy[0].clone()
    for _ in range(49):  # the rest of the 1 s episode
        env.step(actions)
    recorder.close()
    topics = by_topic(read_messages(tmp_path / "e.mcap"))
    first = {t.child_frame_id: t for t in topics["/tf"][0].transforms}
    for i in range(2):
        t = first[f"robot{i}"]
        assert [t.translation.x, t.translation.y] == pytest.approx(robot_xy[i].tolist(), abs=1e-5)
        assert 2 * math.atan2(t.rotation.z, t.rotation.w) == pytest.approx(robot_yaw[i].item(), abs=1e-5)
        assert t.translation.z == pytest.approx(cfg["lowlevel"]["size"][2] / 2)
    assert [first["object"].translation.x, first["object"].translation.y] == pytest.approx(object_xy.tolist(), abs=1e-5)
    disc = next(e for e in topics["/scene"][0].entities if e.id == "subgoal").cylinders[0]
    assert [disc.pose.position.x, disc.pose.position.y] == pytest.approx(subgoal.tolist(), abs=1e-5)
    assert disc.size.x == pytest.approx(2 * cfg["level"]["success_distance"])
    assert len(topics["/tf"]) == 50


def test_a_1000_step_episode_with_3_robots_is_at_most_2_mb(tmp_path, cfg_for):
    # robots that touch end an episode: without that exception the three steady commands run all 20 s
    cfg = cfg_for(
        "task=cylinder", "task.num_agents=3", "level.episode_length_s=20", "~level.exceptions.robot_collision"
    )
    actions = torch.tensor([0.5, 0.2, 0.3]).expand(2, 3, 3)
    record_episode(cfg, tmp_path / "long.mcap", actions, steps=1000)
    info = summary(tmp_path / "long.mcap")
    assert info["topics"]["/scene"]["messages"] == 1000
    assert (tmp_path / "long.mcap").stat().st_size <= 2 * 1024 * 1024


def test_no_episode_file_is_written_before_an_episode_ends(tmp_path, cfg_for):
    record_episode(cfg_for("debug=smoke"), tmp_path / "e.mcap", torch.zeros(2, 2, 3), steps=10)
    assert not (tmp_path / "e.mcap").exists()


@pytest.mark.slow
def test_training_records_episodes_at_the_interval(cli, tmp_path):
    # smoke: 1 s = 50-step episodes, 8 steps per iteration, interval 1; 16 iterations = 128 steps: env 0 ends its
    # first episode within 50 steps and its second within 100, so at least one whole episode is recorded
    proc = cli("train", "debug=smoke", "train.iterations=16", f"train.run_root={tmp_path}")
    assert proc.returncode == 0, proc.stderr
    run_dir = Path(proc.stdout.strip().splitlines()[-1])
    info = summary(run_dir / "train_episodes.mcap")
    assert info["complete"]
    assert info["topics"]["/episode"]["messages"] >= 1
    assert info["topics"]["/scene"]["messages"] >= 50 * info["topics"]["/episode"]["messages"] - 50


@pytest.mark.slow
def test_eval_writes_the_episode_file(cli, run_copy):
    proc = cli("eval", run_copy, "--episodes", "3", "--seeds", "0,1", "log.eval_episodes=2")
    assert proc.returncode == 0, proc.stderr
    topics = by_topic(read_messages(run_copy / "episodes.mcap"))
    assert len(topics["/episode"]) == 4  # 2 recorded episodes x 2 seeds
    assert {e["label"].split(",")[0] for e in topics["/episode"]} == {"seed 0", "seed 1"}
    times = [e["time_s"] for e in topics["/episode"]]
    assert len(topics["/scene"]) == round(sum(times) / 0.02)


# ---------------------------------------------------------------------------------------------------------------
# crash safety

KILL_METRICS = """
import sys
from mapush.logging.metrics import McapLogWriter
writer = McapLogWriter(sys.argv[1], progress=False)
it = 0
while True:
    for k in range(20):
        writer.add_scalar(f"Reward/term{k}", it + k / 100, it)
    writer.end_iteration(it)
    print(it, flush=True)
    it += 1
"""

KILL_EPISODES = """
import sys, torch
from mapush.config import compose_config, to_plain
from mapush.envs.mid import MidPushEnv
from mapush.levels import scene_layout
from mapush.logging.episodes import EpisodeRecorder
from mapush.logging.foxglove_scene import SceneLayout
cfg = to_plain(compose_config(["debug=smoke", "level.episode_length_s=0.2"]))
env = MidPushEnv(cfg, num_envs=1)
recorder = EpisodeRecorder(sys.argv[1] + "/episodes.mcap", SceneLayout.from_config(cfg), list(env.rewards.terms),
                           env.exception_names)
recorder.watch([0], env.dt, "kill", from_start=False, every_steps=1)
env.recorders.append(recorder)
while True:
    before = recorder.written
    env.step(torch.zeros(1, 2, 3))
    if recorder.written > before:
        print(recorder.written, flush=True)
"""


def _kill_after(script: str, directory: Path, lines: int) -> int:
    """Run `script`, SIGKILL it once it has printed `lines` progress lines; returns the last number printed."""
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, "-c", script, str(directory)], stdout=subprocess.PIPE, text=True, env=env)
    last = None
    for _ in range(lines):
        last = int(proc.stdout.readline())
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    return last


def test_sigkilled_metrics_are_recovered_up_to_the_last_flush(tmp_path, cli):
    last = _kill_after(KILL_METRICS, tmp_path, lines=30)
    cut = tmp_path / "metrics.mcap"
    assert not summary(cut)["complete"]
    proc = cli("logs", "recover", cut, "-o", tmp_path / "fixed.mcap")
    assert proc.returncode == 0, proc.stderr
    with open(tmp_path / "fixed.mcap", "rb") as f:
        iterations = {}
        for _, channel, message in make_reader(f).iter_messages():
            iterations.setdefault(channel.topic, set()).add(json.loads(message.data)["iteration"])
    assert len(iterations) == 20
    assert all(set(range(last + 1)) <= its for its in iterations.values())  # every flushed iteration, every tag


@pytest.mark.slow
def test_sigkilled_episode_file_is_recovered_up_to_the_last_episode(tmp_path, cli):
    last = _kill_after(KILL_EPISODES, tmp_path, lines=3)
    proc = cli("logs", "recover", tmp_path / "episodes.mcap", "-o", tmp_path / "fixed.mcap")
    assert proc.returncode == 0, proc.stderr
    topics = by_topic(read_messages(tmp_path / "fixed.mcap"))
    assert len(topics["/episode"]) >= last
    assert len(topics["/scene"]) >= 10 * last  # 0.2 s episodes: 10 steps each


def _start_training(tmp_path: Path, iterations: int, checkpoints: int) -> tuple[subprocess.Popen, Path]:
    """A `debug=smoke` training in a subprocess, once it has written `checkpoints` checkpoints."""
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    cmd = [*MAPUSH, "train", "debug=smoke", f"train.iterations={iterations}", f"train.run_root={tmp_path}"]
    cmd.append("algo.keep_checkpoints=0")  # every checkpoint stays, so their count is the iterations done
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path)
    run_dir = Path(proc.stdout.readline().strip())
    _wait_for(lambda: len(list(run_dir.glob("model_*.pt"))) >= checkpoints)
    return proc, run_dir


@pytest.mark.slow
def test_sigterm_leaves_complete_logs_and_the_run_resumes(cli, tmp_path):
    proc, run_dir = _start_training(tmp_path, iterations=5000, checkpoints=20)
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=60) == 143
    metrics = summary(run_dir / "metrics.mcap")
    assert metrics["complete"]
    assert metrics["topics"]["/metrics/Loss/learning_rate"]["messages"] >= 20
    assert summary(run_dir / "train_episodes.mcap")["complete"]


@pytest.mark.slow
def test_a_sigkilled_run_resumes_with_its_logs_repaired(cli, tmp_path):
    proc, run_dir = _start_training(tmp_path, iterations=30, checkpoints=5)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not summary(run_dir / "metrics.mcap")["complete"]
    resumed = cli("train", "--resume", run_dir)
    assert resumed.returncode == 0, resumed.stderr
    assert "recovered the cut log" in resumed.stderr
    assert summary(run_dir / "metrics.mcap")["complete"]
    from mapush.logging.mcap_files import training_scalars

    assert set(training_scalars(run_dir)["Loss/learning_rate"]) == set(range(30))


def _wait_for(condition, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.1)


# ---------------------------------------------------------------------------------------------------------------
# summary, recover and layout through the CLI


def test_logs_summary_prints_topics_counts_and_span(cli, smoke_run):
    proc = cli("logs", "summary", smoke_run / "metrics.mcap")
    assert proc.returncode == 0, proc.stderr
    assert "complete" in proc.stdout.splitlines()[0]
    assert "messages over" in proc.stdout
    line = next(x for x in proc.stdout.splitlines() if "/metrics/Loss/learning_rate" in x)
    assert line.split()[1:] == ["2", "mapush.Scalar"]


def test_recover_refuses_to_write_an_empty_file(cli, tmp_path):
    data = (REPO / "foxglove" / "mapush-layout.json").read_bytes()
    not_mcap = tmp_path / "x.mcap"
    not_mcap.write_bytes(data)
    proc = cli("logs", "recover", not_mcap, "-o", tmp_path / "out.mcap")
    assert proc.returncode == 2
    assert "not an MCAP file" in proc.stderr
    header_only = tmp_path / "h.mcap"
    header_only.write_bytes(b"\x89MCAP0\r\n")
    proc = cli("logs", "recover", header_only, "-o", tmp_path / "out.mcap")
    assert proc.returncode == 2
    assert "nothing to recover" in proc.stderr
    assert not (tmp_path / "out.mcap").exists()
    proc = cli("logs", "summary", tmp_path / "missing.mcap")
    assert proc.returncode == 2 and "missing.mcap" in proc.stderr


def test_shipped_layout_is_the_generated_one(cfg_for):
    terms = list(RewardManager(cfg_for()["reward"]["terms"]).terms)
    shipped = json.loads((REPO / "foxglove" / "mapush-layout.json").read_text())
    assert shipped == json.loads(episode_layout(terms).to_json())
    panels = json.dumps(shipped)
    assert '"panelType": "ThreeDee"' in panels and '"/commands.vx"' in panels and '"/rewards.total"' in panels


# ---------------------------------------------------------------------------------------------------------------
# plots


def test_plot_draws_a_png_from_a_smoke_run(cli, smoke_run, tmp_path):
    out = tmp_path / "curves.png"
    proc = cli("plot", smoke_run, "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert out.stat().st_size > 10_000


def test_plot_overlays_runs_that_differ_only_in_seed_as_one_group(smoke_run, run_copy, tmp_path):
    import shutil

    from mapush.commands.plot import group_runs, mean_std

    other_seed = tmp_path / "seed1"
    shutil.copytree(smoke_run, other_seed)
    config = other_seed / "config.yaml"
    config.write_text(config.read_text().replace("seed: 0", "seed: 1", 1))
    assert list(group_runs([smoke_run, other_seed]).values()) == [[smoke_run, other_seed]]
    it, mean, std = mean_std([{0: 1.0, 1: 2.0, 2: 4.0}, {0: 3.0, 1: 2.0}], smooth=1)
    assert it.tolist() == [0, 1] and mean.tolist() == [2.0, 2.0] and std.tolist() == [1.0, 0.0]


def test_plot_of_a_dir_that_is_not_a_run_is_bad_input(cli, tmp_path):
    proc = cli("plot", tmp_path)
    assert proc.returncode == 2
    assert "not a run dir" in proc.stderr


# ---------------------------------------------------------------------------------------------------------------
# live view


@pytest.mark.slow
def test_eval_live_serves_the_scene_over_a_foxglove_websocket(run_copy, tmp_path):
    import asyncio
    import socket

    import websockets

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    cmd = [
        *MAPUSH,
        "eval",
        str(run_copy),
        "--live",
        "--episodes",
        "1",
        f"log.live_port={port}",
        "level.episode_length_s=4",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)

    async def watch() -> tuple[dict, bytes]:
        deadline = time.monotonic() + 60
        while True:
            try:
                ws = await websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"])
                break
            except OSError:
                assert time.monotonic() < deadline and proc.poll() is None, "the live server never came up"
                await asyncio.sleep(0.1)
        async with ws:
            channels = {}
            while "/scene" not in channels:
                msg = json.loads(await asyncio.wait_for(ws.recv(), 10))
                if msg["op"] == "advertise":
                    channels.update({c["topic"]: c for c in msg["channels"]})
            scene = channels["/scene"]
            await ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": scene["id"]}]}))
            while True:
                data = await asyncio.wait_for(ws.recv(), 10)
                if isinstance(data, bytes) and data[0] == 1:  # binary opcode 1: message data
                    return scene, data

    scene, data = asyncio.run(watch())
    assert proc.wait(timeout=120) == 0, proc.stderr.read()
    assert scene["schemaName"] == "foxglove.SceneUpdate"
    subscription = int.from_bytes(data[1:5], "little")
    assert subscription == 7
    update = SceneUpdate.FromString(data[13:])  # opcode, subscription id (4), log time (8), payload
    assert {"arena", "object", "robot0", "robot1"} <= {e.id for e in update.entities}


def test_the_hl_scene_shows_each_robots_navigation_goal(tmp_path, cfg_for):
    from mapush.envs.nav_high import NavHighPushEnv

    cfg = cfg_for("level=high_nav", "level.episode_length_s=4")
    env = NavHighPushEnv(cfg, num_envs=1)
    recorder = EpisodeRecorder(
        tmp_path / "e.mcap", SceneLayout.from_config(cfg), list(env.rewards.terms), env.exception_names
    )
    recorder.watch([0], env.frame_dt, "test", from_start=True)
    env.recorders.append(recorder)
    action = torch.tensor([[[1.0, 0.5], [-0.5, -1.0]]])
    env.step(action)
    goals = env.robot_goal_xy[0].clone()  # the first decision's, shown from its first step
    for _ in range(env.max_episode_length - 1):  # the rest of the 4 s episode: only whole episodes are written
        env.step(action)
    recorder.close()
    scene = by_topic(read_messages(tmp_path / "e.mcap"))["/scene"][0]
    discs = next(e for e in scene.entities if e.id == "robot_goals").cylinders
    drawn = [[d.pose.position.x, d.pose.position.y] for d in discs]
    assert torch.allclose(torch.tensor(drawn), goals, atol=1e-5)


def test_the_low_level_scene_draws_every_go1_geom_where_the_simulation_has_it(tmp_path, cfg_for):
    from mapush.envs.locomotion import LocomotionEnv

    cfg = cfg_for("level=locomotion", "level.episode_length_s=0.2")
    env = LocomotionEnv(cfg, num_envs=2, evaluation=True)
    recorder = EpisodeRecorder(tmp_path / "e.mcap", scene_layout(cfg), list(env.rewards.terms), env.exception_names)
    recorder.watch([1], env.dt, "test", from_start=True)
    env.recorders.append(recorder)
    env.step(torch.zeros(2, 1, 12))
    feet = env.geom_xpos[1, np.sort(env.feet)].copy()  # drawn in geom order
    trunk = env.sim.qpos[1, :3].copy()
    for _ in range(9):  # the rest of the 0.2 s episode
        env.step(torch.zeros(2, 1, 12))
    recorder.close()
    topics = by_topic(read_messages(tmp_path / "e.mcap"))
    assert len(topics["/scene"]) == 10 and len(topics["/episode"]) == 1
    robot = next(e for e in topics["/scene"][0].entities if e.id == "robot0")
    assert (len(robot.cubes), len(robot.cylinders), len(robot.spheres)) == (1, 12, 4)  # trunk, legs, feet
    drawn_feet = [[s.pose.position.x, s.pose.position.y, s.pose.position.z] for s in robot.spheres]
    assert np.allclose(drawn_feet, feet, atol=1e-6)
    tf = topics["/tf"][0].transforms[0]
    assert [tf.translation.x, tf.translation.y, tf.translation.z] == pytest.approx(trunk.tolist(), abs=1e-6)
    assert len(topics["/commands"][0]["vx"]) == 1


@pytest.mark.slow
@pytest.mark.parametrize("background", [False, True], ids=["foreground", "background"])
def test_ctrl_c_saves_the_networks_and_prints_the_resume_command(tmp_path, background):
    """SIGINT cuts a run as Ctrl-C does, also one a shell started in the background (SIGINT ignored there)."""
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    cmd = [*MAPUSH, "train", "debug=smoke", "train.iterations=5000", "algo.save_interval=1000"]
    cmd.append(f"train.run_root={tmp_path}")
    ignore = (lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if background else None
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path, preexec_fn=ignore
    )
    run_dir = Path(proc.stdout.readline().strip())
    _wait_for(lambda: (run_dir / "model_0.pt").exists())
    time.sleep(5)  # some iterations past the only checkpoint
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=60) == 130
    assert f"continue with `mapush train --resume {run_dir}`" in proc.stderr.read()
    saved = sorted(run_dir.glob("model_*.pt"), key=lambda p: int(p.stem.partition("_")[2]))
    assert len(saved) == 2 and saved[-1].name != "model_0.pt"
    assert summary(run_dir / "metrics.mcap")["complete"]


@pytest.mark.slow
def test_plot_of_a_run_shorter_than_its_smoothing_window_says_so(cli, smoke_run, tmp_path):
    proc = cli("plot", smoke_run, "--out", tmp_path / "curves.png", "--smooth", "5")
    assert proc.returncode == 0, proc.stderr
    assert "fewer than --smooth 5: drawn unsmoothed" in proc.stderr
    quiet = cli("plot", smoke_run, "--out", tmp_path / "curves1.png", "--smooth", "1")
    assert "warning" not in quiet.stderr
