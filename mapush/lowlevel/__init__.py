"""Low-level backends: what turns each robot's (vx, vy, yaw rate) command into motion.

A backend supplies one robot's MjSpec (attached N times by prefix) and, once the batch exists, reads robot
states and writes commands for all envs and agents at once: `lowlevel=tracker` (a rigid body that tracks the
command with a lag) or `lowlevel=go1` (the legged Go1 and its locomotion policy).
"""

from mapush.config_terms import resolve_term

BACKENDS = {"tracker": "mapush.lowlevel.tracker:Tracker", "go1": "mapush.lowlevel.go1:Go1"}
"""Registry: a low-level config's backend (`backend_name`) -> its class, imported when first used (the Go1's
module loads PyTorch, which reading a config's policy fingerprint or a table does not need)."""


def backend_name(lowlevel: dict) -> str:
    """The backend a low-level config runs on: its `backend`, or else its `name` (`lowlevel=go1_strong` is a Go1)."""
    return lowlevel.get("backend") or lowlevel["name"]


def backend_of(lowlevel: dict):
    """The backend class a low-level config runs on."""
    return resolve_term(BACKENDS[backend_name(lowlevel)], "lowlevel.backend")
