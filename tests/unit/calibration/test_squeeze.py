"""The squeeze sweep (`mapush probe squeeze`): robots pinned between the object and their teammates' pushes."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mapush.calibration import squeeze
from mapush.calibration.capacity import fall_overrides
from mapush.config import compose_config, to_plain

WEAK = fall_overrides({"load_n": 30.0, "width_n": 1.0, "window_s": 1.0, "filter_s": 0.2})
"""A fall curve centred below the tracker's own push (its 52 N cap): a tracker pushing a wall with it falls."""


def test_each_layout_puts_its_robots_in_line_or_across_the_cuboid_without_overlap():
    for name in squeeze.LAYOUTS:
        cfg = to_plain(compose_config(["task=cuboid", f"task.num_agents={squeeze.agents_of(name)}"]))
        layout, _ = squeeze._layout(cfg, name, 3, seed=0)
        xy = layout["robot_xy"]
        assert xy.shape == (3, squeeze.agents_of(name), 2)
        length = cfg["lowlevel"]["size"][0]
        if name in ("across", "2 against 1"):  # robot 0 on the near face, its teammates on the far one, facing it
            assert bool((xy[:, 0, 0] < 0).all() and (xy[:, 1:, 0] > 0).all())
            far = torch.cos(layout["robot_yaw"][:, 1:])
            assert torch.allclose(far, -torch.cos(layout["robot_yaw"][:, :1]).expand_as(far))
            if name == "2 against 1":  # side by side, not overlapping
                assert bool((torch.abs(xy[:, 1, 1] - xy[:, 2, 1]) > cfg["lowlevel"]["size"][1]).all())
        else:  # each robot behind the one ahead, a gap between them
            gaps = -torch.diff(xy[..., 0], dim=1)
            assert bool((gaps > length).all())


@pytest.mark.slow
def test_a_tracker_that_cannot_hold_its_own_push_falls_in_every_layout_and_the_shipped_one_only_when_shoved():
    weak = squeeze.squeeze_sweep(["lowlevel=tracker", *WEAK], envs=2, seed=0)
    shipped = squeeze.squeeze_sweep(["lowlevel=tracker"], envs=2, seed=0)
    assert weak["layout"] == list(squeeze.LAYOUTS)
    assert (weak["fell"] == 1.0).all()  # the measurement can see a fall
    squeezed = np.array([name != "2 against 1" for name in shipped["layout"]])
    assert (shipped["fell"][squeezed] == 0.0).all()  # squeezed, as the Go1, it stands


def test_a_graded_shove_drives_the_lone_robot_back_only_when_the_pair_outpushes_it():
    found = squeeze.shove_sweep(["lowlevel=tracker", "sim.nthread=1"], envs=1, seed=0, pair_speeds=(0.1, 0.5))
    slow, fast = found["speed"]
    assert slow > 0.0 > fast  # a slow pair is pushed back by it; a full-speed pair drives it back
    assert found["fell"][0] == 0.0  # not driven back: no shove hazard


def _shoving(scale: float = 0.1, shape: float = 8.0) -> list[str]:
    """The committed tracker's fall model with a shove curve of scale `scale` m/s."""
    from omegaconf import OmegaConf

    from mapush.config import CONF_DIR

    fall = {**OmegaConf.to_container(OmegaConf.load(CONF_DIR / "lowlevel" / "tracker.yaml").fall)}
    fall = {k: v for k, v in fall.items() if not k.startswith("shove")}
    return fall_overrides({**fall, "shove_mps": scale, "shove_shape": shape})


def test_a_tracker_with_a_shove_curve_falls_when_shoved_back_and_stands_when_squeezed():
    found = squeeze.squeeze_sweep(["lowlevel=tracker", "sim.nthread=1", *_shoving()], envs=2, seed=0)
    fell = dict(zip(found["layout"], found["first_fell"], strict=True))
    assert fell.pop("2 against 1") == 1.0  # driven back at about 0.2 m/s against its command
    assert set(fell.values()) == {0.0}  # pushing, run-up, squeezed in a line or across: never driven back


def test_a_free_tracker_with_a_shove_curve_reversing_its_commands_never_falls():
    """Braking from a reversed command moves a robot against its command too, but no contact drives it."""
    from mapush.calibration.reversals import reversal_sweep

    robots = ["lowlevel=tracker", "sim.nthread=1", *_shoving()]
    found = reversal_sweep(robots, envs=8, seconds=4.0, seed=0, rates=(2.0,))
    assert list(found["fell"]) == [0.0]


def test_a_replayed_command_sequence_is_followed_at_its_own_step_and_a_free_tracker_does_not_fall():
    from mapush.calibration.reversals import replay_sweep

    ahead = np.zeros((10, 3))
    ahead[:5, 0], ahead[5:, 0] = 0.4, -0.4  # 0.5 s ahead, then 0.5 s back, a step every 0.1 s
    found = replay_sweep(["lowlevel=tracker", "sim.nthread=1", *_shoving()], np.stack([ahead, ahead[::-1]]), 0.1, 2)
    assert list(found["fell"]) == [0.0, 0.0]
    vx = found["robot_vel"][..., 0]  # (4, 50): each replay at every 0.02 s step
    half = round(0.5 / found["dt"])
    assert vx.shape == (4, 2 * half)
    assert (vx[:2, half - 1] > 0.3).all() and (vx[:2, -1] < -0.3).all()  # the first sequence, twice
    assert (vx[2:, half - 1] < -0.3).all() and (vx[2:, -1] > 0.3).all()  # the second, reversed


def test_the_shove_fit_recovers_a_known_curve_from_synthetic_falls():
    """Starts held at a constant shove speed per group: their fall shares from a known curve, over many trials."""
    scale, shape, window, dt, steps = 0.15, 6.0, 4.0, 0.02, 300
    speeds = np.array([0.0, 0.1, 0.15, 0.2, 0.3])
    group = np.repeat(np.arange(len(speeds)), 3)
    load_rate = 0.01  # 1/s, the contact load's hazard, the same in every start
    traces = {"shove": np.repeat(speeds[group][:, None], steps, 1), "group": group, "dt": dt}
    traces["load_rate"] = np.full((len(group), steps), load_rate)
    share = 1.0 - np.exp(-((speeds / scale) ** shape / window + load_rate) * steps * dt)
    trials = np.full(len(speeds), 10_000)
    fit = squeeze.fit_shove_curve(traces, np.round(share * trials), trials, window)
    assert fit["shove_mps"] == pytest.approx(scale, abs=0.005)
    assert fit["shove_shape"] == pytest.approx(shape, rel=0.15)
    assert squeeze.fit_shove_curve(traces, np.zeros(len(speeds)), trials, window) is None  # no fall: no curve
    only_unshoved = np.array([10.0, 0, 0, 0, 0])  # falls only where the tracker was never shoved: nothing to fit
    assert squeeze.fit_shove_curve(traces, only_unshoved, trials, window) is None
    assert squeeze.shove_at_grid_bound(fit) is None
    assert "lower bound" in squeeze.shove_at_grid_bound({"shove_mps": squeeze.SHOVE_SCALES[0], "shove_shape": 2.0})


def test_the_fits_hazard_is_the_one_the_tracker_accumulates():
    """The fit rebuilds each start's hazard from `tracker_shoves`' traces: it must equal what the tracker's own fall
    model summed in the same graded shove (the settle before it adds next to nothing: no contact, no command)."""
    from omegaconf import OmegaConf

    from mapush.config import CONF_DIR

    fall = OmegaConf.to_container(OmegaConf.load(CONF_DIR / "lowlevel" / "tracker.yaml").fall)
    fall.update(shove_mps=0.193, shove_shape=2.12)  # a shove curve (the fit of 2026-11-30) on the committed model
    robots = {}

    def keep(sim) -> None:
        robots["tracker"] = sim.lowlevel

    overrides = ["lowlevel=tracker", "sim.nthread=1", *fall_overrides(fall)]
    traces = squeeze.tracker_shoves(overrides, envs=1, seed=0, pair_speeds=(0.2, 0.5))
    squeeze._graded_shove(overrides, 1, 0, (0.2, 0.5), after=keep)
    shove_rate = (traces["shove"] / fall["shove_mps"]) ** fall["shove_shape"] / fall["window_s"]
    rebuilt = ((shove_rate + traces["load_rate"]).sum(1)) * traces["dt"]
    assert rebuilt[1] > 0.5  # the full-speed pair shoved it: a hazard worth checking
    assert np.allclose(rebuilt, robots["tracker"].hazard[:, 0], rtol=1e-6, atol=1e-9)
