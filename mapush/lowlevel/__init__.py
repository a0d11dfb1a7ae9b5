"""Low-level backends: what turns each robot's (vx, vy, yaw rate) command into motion.

A backend supplies one robot's MjSpec (attached N times by prefix) and, once the batch exists, reads robot
states and writes commands for all envs and agents at once. `lowlevel=tracker` is the only backend so far.
"""

from mapush.lowlevel.tracker import Tracker

BACKENDS = {"tracker": Tracker}
"""Registry: the `lowlevel.name` of a config -> its backend class."""
