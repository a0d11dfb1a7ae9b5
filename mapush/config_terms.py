"""Config terms: a named function `module:function` with its params, as the reward, observation, exception and
event sections of a level's config name them (`{name: {func, params, ...}}`; an event names a class). Resolved and
checked once, when the env is built: a bad path or a params mismatch is one BadInput line naming the valid choices.
Only code of trusted modules is imported (`mapush.trust`)."""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable
from dataclasses import dataclass, field

from mapush.errors import BadInput
from mapush.trust import check_trusted


def resolve_term(path: str, key: str = "func") -> Callable:
    """Import `module:function` from a trusted module; a bad path is a BadInput naming the module's public
    functions."""
    check_trusted(key, path)
    module_name, _, func_name = path.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as err:
        raise BadInput(f"term function module {module_name!r} cannot be imported ({err})") from None
    func = getattr(module, func_name, None)
    if not callable(func):
        valid = sorted(
            n
            for n, f in vars(module).items()
            if (inspect.isfunction(f) or getattr(f, "is_event_term", False))  # events are classes
            and not n.startswith("_")
            and f.__module__ == module.__name__
        )
        raise BadInput(f"unknown term function {path!r}; valid in {module_name}: {', '.join(valid)}")
    return func


@dataclass(frozen=True)
class Term:
    """One resolved term: `func(env, **params)`."""

    name: str
    func: Callable
    params: dict = field(default_factory=dict)

    def __call__(self, env):
        return self.func(env, **self.params)


def check_replaced_events(section: str, terms: dict | None, replaced: dict | None) -> None:
    """BadInput when a section that replaces some events' params (`section`: `level.eval_events`) names an event
    that the events it replaces them in (`terms`: `level.events`) do not list. Needs no event's code: told before
    training's imports."""
    unknown = sorted(set(replaced or {}) - set(terms or {}))
    if unknown:
        raise BadInput(f"{section}.{unknown[0]} names no event; valid: {', '.join(terms or {})}")


def bind_term(section: str, name: str, spec: dict) -> Term:
    """The term `name` of a config section (e.g. `reward.terms`) from `{func, params}`, its params checked against
    the function's signature. A param with a default may be left out: the default keeps runs saved before it
    existed as they were."""
    if not isinstance(spec, dict) or "func" not in spec:
        raise BadInput(f"{section}.{name} is {spec!r}; valid: a mapping with func: module:function and params")
    func = resolve_term(spec["func"], f"{section}.{name}.func")
    params = dict(spec.get("params") or {})
    signature = inspect.signature(func).parameters
    wanted = list(signature)[1:]
    required = {p for p in wanted if signature[p].default is inspect.Parameter.empty}
    if not required <= set(params) <= set(wanted):
        raise BadInput(f"{section}.{name} ({spec['func']}) takes params {wanted}, config gives {sorted(params)}")
    for param, value in params.items():
        _check_type(f"{section}.{name}.params.{param}", value, signature[param].annotation)
    return Term(name, func, params)


PARAM_TYPES = {"float": (int, float), "int": (int,), "str": (str,), "bool": (bool,)}
"""Annotations of term params that are checked, and the Python types a config value of each may have."""


def _check_type(key: str, value, annotation) -> None:
    """BadInput unless `value` fits a param annotated `float`, `int`, `str` or `bool` (others are not checked)."""
    name = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", "")
    types = PARAM_TYPES.get(name)
    if types is None:
        return
    if not isinstance(value, types) or (name in ("float", "int") and isinstance(value, bool)):
        raise BadInput(f"{key}={value!r} is not of type {name}; valid: a value of type {name}")


def bind_terms(section: str, specs: dict) -> list[Term]:
    """Every term of a config section, in its order; a null entry drops the term."""
    return [bind_term(section, name, spec) for name, spec in specs.items() if spec is not None]
