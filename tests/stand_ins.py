"""Stand-in envs for the tests of pure term functions: only the attributes a term reads, state fields under
`env.state` as the real envs keep them (`PushState`, `LocomotionState`)."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

from mapush.envs.low import LocomotionState
from mapush.sim.push import PushState

STATE_FIELDS = {f.name for f in dataclasses.fields(PushState)} | {f.name for f in dataclasses.fields(LocomotionState)}


def stand_in_env(**attrs) -> SimpleNamespace:
    """An env whose state fields (e.g. `object_xy`, `lin_vel`) are under `.state` and the rest on the env itself."""
    state = {name: attrs.pop(name) for name in list(attrs) if name in STATE_FIELDS}
    return SimpleNamespace(state=SimpleNamespace(**state), **attrs)
