"""The Foxglove layout for mapush's episode files, built with the Foxglove SDK's layout API.

`foxglove/mapush-layout.json` in the repo is this layout (`mapush logs layout -o foxglove/mapush-layout.json`
rewrites it; a test checks that it is up to date). In Foxglove: open an `episodes.mcap`, then Layouts -> Import.
"""

from __future__ import annotations

import foxglove.layouts as fl

from mapush.logging.foxglove_scene import WORLD

COMMAND_FIELDS = ("vx", "vy", "yaw_rate")


def _by_robot(topic_field: str, label: str) -> fl.PlotSeries:
    """One series per robot from an array field (index = robot)."""
    return fl.PlotSeries(value=topic_field, label=label, timestamp_method="receiveTime", array_expansion="byIndex")


def episode_layout(reward_terms: list[str]) -> fl.Layout:
    """3D scene (left); per-robot commands, rewards and the episode log (right)."""
    scene = fl.ThreeDeePanel(
        title="scene",
        config=fl.ThreeDeeConfig(
            follow_tf=WORLD,
            camera_state=fl.ThreeDeeCameraState(distance=18.0, perspective=True, phi=40.0, target=(0.0, 0.0, 0.0)),
        ),
    )
    commands = fl.PlotPanel(
        title="velocity commands (per robot)",
        config=fl.PlotConfig(paths=[_by_robot(f"/commands.{f}", f) for f in COMMAND_FIELDS], show_legend=True),
    )
    totals = fl.PlotPanel(
        title="reward per robot",
        config=fl.PlotConfig(paths=[_by_robot("/rewards.total", "total")], show_legend=True),
    )
    terms = fl.PlotPanel(
        title="reward terms (robot 0)",
        config=fl.PlotConfig(
            paths=[
                fl.PlotSeries(value=f"/rewards.{t}[0]", label=t, timestamp_method="receiveTime") for t in reward_terms
            ],
            show_legend=True,
        ),
    )
    log = fl.LogPanel(title="episodes", config=fl.LogConfig(topic_to_render="/log", show_time=True))
    side = fl.SplitContainer(
        direction="column",
        items=[fl.SplitItem(content=p) for p in (commands, totals, terms)]
        + [fl.SplitItem(proportion=0.6, content=log)],
    )
    return fl.Layout(
        content=fl.SplitContainer(
            direction="row", items=[fl.SplitItem(proportion=1.6, content=scene), fl.SplitItem(content=side)]
        )
    )
