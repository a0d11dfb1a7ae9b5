"""What happened in each episode, whatever ended it: falls, robot contacts and object tilts, counted per episode.

Under `rules=original` a fall or a contact does not end a long-horizon episode, so its exception rate cannot say
how often robots fell; these counts can, under either rules. Evaluation envs count them and report them in each
episode's outcome (`episode_end`: `falls`, the robots that fell; `robot_contacts` and `object_tilts`, how often
robots came to touch and the object tipped past the threshold), which `mapush eval` writes to eval.json (`events`).
"""

from __future__ import annotations

import torch

from mapush.envs import terminations

EVENTS = ("falls", "robot_contacts", "object_tilts")
"""The per-episode counts, as `episode_end` and eval.json name them."""


class EpisodeEvents:
    """Per-env counts for the episodes running now: the robots that fell (a fallen robot counts once, fallen for
    good or not), and the onsets of robot contact and of object tilt (a contact held for seconds counts once).

    `thresholds` is the config's `eval.events`: `fall_tilt_rad` (a robot tilted further has fallen),
    `object_tilt_rad` (an object tilted further has tipped), `contact_tolerance_m` (footprints this close touch);
    conf/config.yaml gives their sources."""

    def __init__(self, num_envs: int, num_agents: int, thresholds: dict):
        self.fall_tilt = float(thresholds["fall_tilt_rad"])
        self.object_tilt = float(thresholds["object_tilt_rad"])
        self.contact_tolerance = float(thresholds["contact_tolerance_m"])
        self.fell = torch.zeros(num_envs, num_agents, dtype=torch.bool)
        self.touching = torch.zeros(num_envs, dtype=torch.bool)
        self.tilted = torch.zeros(num_envs, dtype=torch.bool)
        self.contacts = torch.zeros(num_envs)
        self.tilts = torch.zeros(num_envs)

    def update(self, env, live: torch.Tensor) -> None:
        """Count this physics step's events of the envs `live` (E,) whose episode is still running."""
        s = env.state
        self.fell |= (s.robot_tilt > self.fall_tilt) & live.unsqueeze(-1)
        touching = terminations.robot_contact(env, self.contact_tolerance) if env.num_agents > 1 else self.touching
        tilted = s.object_tilt > self.object_tilt
        self.contacts += (touching & ~self.touching & live).float()
        self.tilts += (tilted & ~self.tilted & live).float()
        self.touching, self.tilted = touching, tilted

    def reset(self, t: torch.Tensor) -> None:
        """Start counting anew in envs `t` (a new episode)."""
        self.fell[t], self.touching[t], self.tilted[t], self.contacts[t], self.tilts[t] = False, False, False, 0, 0

    def counts(self) -> dict[str, torch.Tensor]:
        """{event: (E,) count this episode so far}."""
        return {"falls": self.fell.sum(-1).float(), "robot_contacts": self.contacts, "object_tilts": self.tilts}
