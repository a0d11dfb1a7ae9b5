"""Low-level backends: what turns each robot's (vx, vy, yaw rate) command into motion.

A backend supplies one robot's MjSpec (attached N times by prefix) and, once the batch exists, reads robot
states and writes commands for all envs and agents at once: `lowlevel=tracker` (a rigid body that tracks the
command with a lag) or `lowlevel=go1` (the legged Go1 and its locomotion policy).
"""

from mapush.lowlevel.go1 import Go1
from mapush.lowlevel.tracker import Tracker

BACKENDS = {"tracker": Tracker, "go1": Go1}
"""Registry: the `lowlevel.name` of a config -> its backend class."""
