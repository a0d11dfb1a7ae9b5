"""The squeeze sweep (`mapush probe squeeze`): robots pinned between the object and their teammates' pushes."""

from __future__ import annotations

import pytest
import torch

from mapush.calibration import squeeze
from mapush.calibration.capacity import fall_override
from mapush.config import compose_config, to_plain

WEAK = fall_override({"load_n": 30.0, "width_n": 1.0, "window_s": 1.0, "filter_s": 0.2})
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
def test_a_tracker_that_cannot_hold_its_own_push_falls_in_every_layout_and_the_shipped_one_in_none():
    weak = squeeze.squeeze_sweep(["lowlevel=tracker", f"lowlevel.fall={WEAK}"], envs=2, seed=0)
    shipped = squeeze.squeeze_sweep(["lowlevel=tracker"], envs=2, seed=0)
    assert weak["layout"] == list(squeeze.LAYOUTS)
    assert (weak["fell"] == 1.0).all()  # the measurement can see a fall
    assert (shipped["fell"] == 0.0).all()


def test_a_graded_shove_drives_the_lone_robot_back_only_when_the_pair_outpushes_it():
    found = squeeze.shove_sweep(["lowlevel=tracker", "sim.nthread=1"], envs=1, seed=0, pair_speeds=(0.1, 0.5))
    slow, fast = found["speed"]
    assert slow > 0.0 > fast  # a slow pair is pushed back by it; a full-speed pair drives it back
    assert list(found["fell"]) == [0.0, 0.0]  # the shipped tracker's load reads its own cap: it never falls
