"""The reward manager: (func, weight, params) terms from config, summed into one reward per agent."""

from __future__ import annotations

import torch

from mapush.config_terms import bind_term


class RewardManager:
    """Weighs and sums reward terms. Checks at construction that each term's params match its signature.

    Args:
        terms_cfg: {name: {func, weight, params, terminal}}; a null entry or weight 0 drops the term.
        positive_only: clip the sum of the non-`terminal` terms at 0 before adding the terminal ones (legged_gym's
            `only_positive_rewards`, Rudin et al. 2022): early in training the penalties would otherwise teach a
            falling robot that ending the episode pays.
    """

    def __init__(self, terms_cfg: dict, positive_only: bool = False):
        self.positive_only = positive_only
        self.terminal = set()
        self.terms = {}
        for name, term in terms_cfg.items():
            if term is None or term.get("weight", 0.0) == 0.0:
                continue
            bound = bind_term("reward.terms", name, term)
            self.terms[name] = (bound.func, float(term["weight"]), bound.params)
            if term.get("terminal", False):
                self.terminal.add(name)

    def compute(self, env) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        """Total reward (E, A) and each weighted term (E, A), by name."""
        parts = {name: weight * func(env, **params) for name, (func, weight, params) in self.terms.items()}
        shaping = [value for name, value in parts.items() if name not in self.terminal]
        terminal = [value for name, value in parts.items() if name in self.terminal]
        total = torch.stack(shaping).sum(0) if shaping else torch.zeros(env.num_envs, env.num_agents)
        if self.positive_only:
            total = total.clamp(min=0.0)
        return (total + torch.stack(terminal).sum(0) if terminal else total), parts
