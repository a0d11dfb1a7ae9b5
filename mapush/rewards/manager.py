"""The reward manager: (func, weight, params) terms from config, summed into one reward per agent."""

from __future__ import annotations

import importlib
import inspect

import torch

from mapush.errors import BadInput


def resolve_term(path: str):
    """Import `module:function`; a bad path is a BadInput naming the module's public functions."""
    module_name, _, func_name = path.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as err:
        raise BadInput(f"reward function module {module_name!r} cannot be imported ({err})") from None
    func = getattr(module, func_name, None)
    if not callable(func):
        valid = sorted(
            n
            for n, f in vars(module).items()
            if inspect.isfunction(f) and not n.startswith("_") and f.__module__ == module.__name__
        )
        raise BadInput(f"unknown reward function {path!r}; valid in {module_name}: {', '.join(valid)}")
    return func


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
            func = resolve_term(term["func"])
            params = dict(term.get("params") or {})
            signature = inspect.signature(func).parameters
            wanted = list(signature)[1:]
            # a param with a default may be left out: the default keeps runs saved before it existed as they were
            required = {p for p in wanted if signature[p].default is inspect.Parameter.empty}
            if not required <= set(params) <= set(wanted):
                raise BadInput(
                    f"reward term {name!r} ({term['func']}) takes params {wanted}, config gives {sorted(params)}"
                )
            self.terms[name] = (func, float(term["weight"]), params)
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
