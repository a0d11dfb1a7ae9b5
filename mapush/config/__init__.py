"""mapush's configs: composing them from the CLI and tests, checking overrides, and a run dir's config files.

One module per job: `groups` (the config tree, its groups and their options), `overrides` (Hydra's override
grammar, on a saved config too), `compose` (composing, and reading a composed config), `git` (the checkout's state
a run records), `run_files` (a new run dir and the files that say what made it) and `run_config` (a saved run's
config read against today's defaults). Importing the package registers the configs' resolvers (`mapush.resolvers`).
"""

from __future__ import annotations

import sys
import types

from mapush.config import groups
from mapush.config.compose import COMPOSED_KEPT, compose_config, env_steps_per_iteration, sim_threads, to_plain
from mapush.config.git import git_state
from mapush.config.groups import GROUPS, group_file, group_options, search_dirs
from mapush.config.overrides import SWAPPABLE_GROUPS, apply_overrides, overrides_name
from mapush.config.run_config import level_defaults, load_run_config
from mapush.config.run_files import META_FILE, lengthen_run, new_run_dir, save_run_config
from mapush.resolvers import register_resolvers

register_resolvers()


class _ConfigPackage(types.ModuleType):
    """`mapush.config`, whose `CONF_DIR` is `groups.CONF_DIR` read and set: every module of the package reads the
    tree from there when called, so that `mapush.config.CONF_DIR = copy` (a test's monkeypatch) composes from the
    copy, as it did when the package was one module."""

    @property
    def CONF_DIR(self):
        return groups.CONF_DIR

    @CONF_DIR.setter
    def CONF_DIR(self, value):
        groups.CONF_DIR = value


sys.modules[__name__].__class__ = _ConfigPackage

__all__ = [
    "COMPOSED_KEPT",
    "CONF_DIR",
    "GROUPS",
    "META_FILE",
    "SWAPPABLE_GROUPS",
    "apply_overrides",
    "compose_config",
    "env_steps_per_iteration",
    "git_state",
    "group_file",
    "group_options",
    "lengthen_run",
    "level_defaults",
    "load_run_config",
    "new_run_dir",
    "overrides_name",
    "save_run_config",
    "search_dirs",
    "sim_threads",
    "to_plain",
]
