"""What happened in each episode, whatever ended it: falls, robot contacts and object tilts, counted per episode.

Under `rules=original` a fall or a contact does not end a long-horizon episode, so its exception rate cannot say
how often robots fell; these counts can, under either rules. Evaluation envs count them and report them in each
episode's outcome (`episode_end`: `falls`, the robots that fell; `robot_contacts` and `object_tilts`, how often
robots came to touch and the object tipped past the threshold), which `mapush eval` writes to eval.json (`events`).
"""

from __future__ import annotations

import torch

from mapush.envs import terminations

FALL_TILT_RAD = 0.8
"""rad; a robot tilted further has fallen: the pushing levels' `robot_tilt` threshold (the original's roll limit)."""
OBJECT_TILT_RAD = 0.8
"""rad; an object tilted further has tipped: the levels' `object_tilt` threshold."""
CONTACT_TOLERANCE_M = 0.01
"""m; robots whose footprints come this close touch: the levels' `robot_collision` tolerance."""
EVENTS = ("falls", "robot_contacts", "object_tilts")
"""The per-episode counts, as `episode_end` and eval.json name them."""


class EpisodeEvents:
    """Per-env counts for the episodes running now: the robots that fell (a fallen robot counts once, fallen for
    good or not), and the onsets of robot contact and of object tilt (a contact held for seconds counts once)."""

    def __init__(self, num_envs: int, num_agents: int):
        self.fell = torch.zeros(num_envs, num_agents, dtype=torch.bool)
        self.touching = torch.zeros(num_envs, dtype=torch.bool)
        self.tilted = torch.zeros(num_envs, dtype=torch.bool)
        self.contacts = torch.zeros(num_envs)
        self.tilts = torch.zeros(num_envs)

    def update(self, env, live: torch.Tensor) -> None:
        """Count this physics step's events of the envs `live` (E,) whose episode is still running."""
        s = env.state
        self.fell |= (s.robot_tilt > FALL_TILT_RAD) & live.unsqueeze(-1)
        touching = terminations.robot_contact(env, CONTACT_TOLERANCE_M) if env.num_agents > 1 else self.touching
        tilted = s.object_tilt > OBJECT_TILT_RAD
        self.contacts += (touching & ~self.touching & live).float()
        self.tilts += (tilted & ~self.tilted & live).float()
        self.touching, self.tilted = touching, tilted

    def reset(self, t: torch.Tensor) -> None:
        """Start counting anew in envs `t` (a new episode)."""
        self.fell[t], self.touching[t], self.tilted[t], self.contacts[t], self.tilts[t] = False, False, False, 0, 0

    def counts(self) -> dict[str, torch.Tensor]:
        """{event: (E,) count this episode so far}."""
        return {"falls": self.fell.sum(-1).float(), "robot_contacts": self.contacts, "object_tilts": self.tilts}
