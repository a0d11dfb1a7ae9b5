"""The env core every level is built on: the step skeleton, episode bookkeeping, resets, recorder hooks, and the
observation and exception terms its config names.

A level subclasses `EnvCore` and supplies what is its own: the simulation (`BatchSim` or `PushSim`), how episodes
start (`_start_episodes`), its state (`_read_state`), and the body of `step` up to the reward. The rest comes from
the config: reward terms (`reward.terms`), observation terms (`level.observations`: groups `policy` and `critic`,
each a list of named terms concatenated in order) and exception terms (`level.exceptions`: checked in order, the
first that fires names the exception). A level is mostly its YAML file.

One step: actions -> physics -> state -> exceptions and terminations -> rewards (before any reset) -> recorders ->
episode outcomes -> reset finished envs -> observations (docs/design.md, "One environment step").
"""

from __future__ import annotations

import math

import numpy as np
import torch

from mapush.config_terms import Term, bind_terms
from mapush.rewards.manager import RewardManager

RECENT_EPISODES = 500
"""Episodes in the rolling success rate that is logged every step (`Metrics/recent_success_rate`)."""


def exception_names(cfg: dict) -> tuple[str, ...]:
    """The exception kinds of a config's level, in the order `exception_kind` indexes them."""
    return tuple(name for name, spec in cfg["level"]["exceptions"].items() if spec is not None)


class EnvCore:
    """E envs with `rows` policy rows each (agents, or one per team), stepped as one batch.

    A level subclasses it and writes `step` (ending in `_finish_step`), `_start_episodes`, `_read_state` and
    `scene_frame`, sets `num_actions`, and adds its own config checks to `validate`.

    `action_limit`: |action| the env acts on; a step clips actions to it, so beyond it an action changes nothing.

    Attributes every level has (E = `num_envs`):
        episode_step (E,) policy steps this episode; success, exception (E,) this step's flags;
        exception_kind (E,) index into `exception_names`, -1 for none; episode_sums {reward term: (E, rows)};
        recorders: `EpisodeRecorder` / `LiveView` objects (mapush.logging.episodes) captured every step.

    Args:
        cfg: the composed config as a plain dict.
        sim: the level's simulation (`BatchSim`).
        num_envs: E.
        num_agents: robots per env.
        rows: policy rows per env (rsl-rl sees E x rows rows).
        dt: seconds per policy step.
    """

    action_limit = 1.0

    def __init__(self, cfg: dict, sim, num_envs: int, num_agents: int, rows: int, dt: float):
        self.cfg = cfg
        self.sim = sim
        self.num_envs = E = num_envs
        self.num_agents = num_agents
        self.policy_agents = rows
        self.dt = dt
        self.frame_dt = dt  # interval between recorder captures
        # the tolerance keeps 0.14 s / 0.02 s = 7.000000000000001 at 7 steps
        self.max_episode_length = math.ceil(cfg["level"]["episode_length_s"] / dt - 1e-9)
        self.generator = torch.Generator().manual_seed(int(cfg["seed"]))
        self.rewards = RewardManager(cfg["reward"]["terms"], cfg["reward"].get("positive_only", False))
        self.observation_terms = observation_terms(cfg)
        self.exception_terms = bind_terms("level.exceptions", cfg["level"]["exceptions"])
        self.exception_names = tuple(term.name for term in self.exception_terms)
        self.episode_step = torch.zeros(E, dtype=torch.long)
        self.success = torch.zeros(E, dtype=torch.bool)
        self.exception = torch.zeros(E, dtype=torch.bool)
        self.exception_kind = torch.full((E,), -1)
        self.diverged = torch.zeros(E, dtype=torch.bool)  # the simulation failed or left the finite numbers
        self.episode_sums = {name: torch.zeros(E, rows) for name in self.rewards.terms}
        self.last_reward = torch.zeros(E, rows)  # the latest step's reward and its weighted terms
        self.last_parts = {name: torch.zeros(E, rows) for name in self.rewards.terms}
        self.outcomes = EpisodeOutcomes()
        self.recorders = []

    num_actions: int
    """Action width of one policy row."""

    @classmethod
    def validate(cls, cfg: dict) -> None:
        """Check a config before anything is built or written (BadInput); a level adds its own checks."""
        cls.check_terms(cfg)

    def step(self, actions: torch.Tensor) -> tuple[dict, torch.Tensor, torch.Tensor, torch.Tensor, dict]:
        """One policy step of every env: act, simulate, read the state, flag exceptions, reward (before any reset),
        then `_finish_step`. Returns observations, reward (E, rows), terminated, truncated (E,) and info."""
        raise NotImplementedError

    def scene_frame(self) -> dict[str, torch.Tensor]:
        """What a viewer draws of every env now (before resets), by name: tensors over the envs."""
        raise NotImplementedError

    @staticmethod
    def check_terms(cfg: dict) -> None:
        """Resolve the config's reward, observation and exception terms (BadInput for a bad one), building nothing."""
        RewardManager(cfg["reward"]["terms"])
        observation_terms(cfg)
        bind_terms("level.exceptions", cfg["level"]["exceptions"])

    def seed(self, seed: int) -> None:
        """Reseed what draws the episodes' starts (the next resets draw from it)."""
        self.generator.manual_seed(int(seed))

    # ----------------------------------------------------------------------------------------------------------
    def reset(self, ids: np.ndarray) -> None:
        """Start new episodes in envs `ids`: the level's start (`_start_episodes`), zeroed counters, fresh state."""
        if len(ids) == 0:
            return
        t = torch.from_numpy(ids)
        self._start_episodes(ids, t)
        self.episode_step[t] = 0
        for sums in self.episode_sums.values():
            sums[t] = 0.0
        self._read_state()
        self._started(t)

    def _start_episodes(self, ids: np.ndarray, t: torch.Tensor) -> None:
        """Sample and write the start of envs `ids` (`t` the same ids as a tensor) into the simulation."""
        raise NotImplementedError

    def _read_state(self) -> None:
        """Refresh `self.state` (and what the level derives from it) from the simulation."""
        raise NotImplementedError

    def _started(self, t: torch.Tensor) -> None:
        """After a reset's state is read: what the level sets from the new state of envs `t`."""

    @property
    def episode_time_s(self) -> torch.Tensor:
        """Simulated time of each env's episode, s."""
        return self.episode_step.float() * self.dt

    # ----------------------------------------------------------------------------------------------------------
    def observations(self) -> dict[str, torch.Tensor]:
        """Each group of `level.observations` (`policy`, `critic`): its terms concatenated, (E, rows, d), NaN-free.
        A term gives (E, rows, d) or (E, d), the latter shared by every row; one used twice is computed once."""
        computed = {}
        out = {}
        for group, terms in self.observation_terms.items():
            parts = []
            for term in terms:
                key = (term.func, repr(term.params))
                if key not in computed:
                    computed[key] = term(self)
                value = computed[key]
                if value.dim() == 2:
                    value = value.unsqueeze(1).expand(-1, self.policy_agents, -1)
                parts.append(value)
            out[group] = torch.nan_to_num(torch.cat(parts, -1), 0.0, 0.0, 0.0)
        return out

    def exception_flags(self) -> torch.Tensor:
        """(len(exception_names), E) flags of the exception terms, in their order."""
        return torch.stack([term(self) for term in self.exception_terms])

    def first_exception(self, flags: torch.Tensor) -> torch.Tensor:
        """(E,) index of the first flag that fired in (kinds, E) `flags`, -1 for none."""
        return torch.where(flags.any(0), flags.int().argmax(0), -1)

    def _finish_step(
        self,
        reward: torch.Tensor,
        parts: dict[str, torch.Tensor],
        terminated: torch.Tensor,
        truncated: torch.Tensor,
        commands: torch.Tensor | None,
    ) -> tuple[dict, torch.Tensor, torch.Tensor, torch.Tensor, dict]:
        """The end of every level's step: episode sums, recorders (given the step's `commands`; None when the level
        captured them itself), outcomes of the episodes that end, resets, and the new observations."""
        reward = torch.nan_to_num(reward, 0.0, 0.0, 0.0)
        for name, value in parts.items():
            self.episode_sums[name] += torch.nan_to_num(value, 0.0, 0.0, 0.0)
        self.last_reward, self.last_parts = reward, parts
        done = terminated | truncated
        if commands is not None:
            for recorder in self.recorders:
                recorder.capture(self, commands, reward, parts, done)
        info = self._episode_info(done)
        self._before_reset(done)
        self.reset(done.nonzero().flatten().numpy())
        return self.observations(), reward, terminated, truncated, info

    def _before_reset(self, done: torch.Tensor) -> None:
        """After a step's outcomes are recorded, before the envs `done` restart."""

    def _episode_info(self, done: torch.Tensor) -> dict:
        """Outcomes of the episodes ending now: per-env `episode_end` and the `log` means rsl-rl records."""
        return self.outcomes.info(self.episode_end(done, self.exception), self.episode_sums)

    def episode_end(self, done: torch.Tensor, failed: torch.Tensor) -> dict[str, torch.Tensor]:
        """Per-env outcomes of the episodes ending now (`done`), as every env reports them in `info["episode_end"]`.

        Args:
            failed: the envs whose episode ends as an exception (a failure).
        """
        return {
            "done": done.clone(),
            "success": self.success & done,
            "exception": failed & done,
            "diverged": self.diverged & done,
            "exception_kind": torch.where(done, self.exception_kind, -1),
            "time_s": self.episode_time_s,
        }


def observation_terms(cfg: dict) -> dict[str, list[Term]]:
    """The observation groups of a config's level, each a list of resolved terms."""
    groups = cfg["level"]["observations"]
    return {group: bind_terms(f"level.observations.{group}", specs) for group, specs in groups.items()}


class EpisodeOutcomes:
    """A ring buffer of the latest episodes' successes, and the `info` an env step returns about finished ones.

    `part_way` marks envs whose running episode began part-way through (a resumed run's episodes spread over
    their length, `AgentRowsVecEnv.episode_length_buf`): such an episode is shorter than any whole one, so it
    stays out of the logged means and the recent success rate, which go on from the run's restored readouts.
    """

    def __init__(self):
        self.recent_success = torch.full((RECENT_EPISODES,), float("nan"))
        self._next = 0
        self.part_way: torch.Tensor | None = None  # (E,) bool, set by the learner's wrapper on a resume

    def readouts(self) -> dict:
        """The rolling success window, to keep in a checkpoint."""
        return {"recent_success": self.recent_success.tolist(), "next": self._next}

    def restore(self, saved: dict) -> None:
        """Continue the rolling success window of a checkpoint (`readouts`)."""
        window = torch.tensor(saved["recent_success"], dtype=torch.float)
        if window.shape == self.recent_success.shape:
            self.recent_success, self._next = window, int(saved["next"]) % RECENT_EPISODES

    def info(self, end: dict[str, torch.Tensor], episode_sums: dict, extra: dict | None = None) -> dict:
        """`{"episode_end": end, "log": ...}`: the log means over the episodes that end now (`end["done"]`).

        Args:
            end: per-env outcomes with at least `done`, `success`, `exception` (masked by done) and `time_s`.
            episode_sums: reward term -> (E, rows) episode sums.
            extra: more per-env values (E,) to log as `Metrics/<name>` means over the finished episodes.
        """
        done = end["done"]
        if self.part_way is not None:  # count only whole episodes; an env's next episode is whole
            done = done & ~self.part_way
            self.part_way &= ~end["done"]
        if not done.any():
            return {"episode_end": end, "log": {"Metrics/recent_success_rate": self.recent_success.nanmean()}}
        outcomes = end["success"][done].float()[-RECENT_EPISODES:]
        slots = (self._next + torch.arange(len(outcomes))) % RECENT_EPISODES
        self.recent_success[slots] = outcomes
        self._next = int(slots[-1] + 1) % RECENT_EPISODES
        log = {f"Reward/{name}": sums[done].mean() for name, sums in episode_sums.items()}
        log["Metrics/success_rate"] = end["success"][done].float().mean()
        log["Metrics/exception_rate"] = end["exception"][done].float().mean()
        for name, values in (extra or {}).items():
            log[f"Metrics/{name}"] = values[done].float().mean()
        log["Metrics/episode_time_s"] = end["time_s"][done].mean()
        log["Metrics/recent_success_rate"] = self.recent_success.nanmean()
        return {"episode_end": end, "log": log}
