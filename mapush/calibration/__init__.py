"""`mapush calibrate`: what a legged low level can do, measured, and the tracker that stands for it.

`lags.py` (how fast it follows a command), `capacity.py` (how hard it pushes, what load topples it), `run.py`
(the experiments in order, the record and its plot), `tracker_option.py` (the fitted tracker written into the
output dir as a `lowlevel=` option of its own: the package's `conf/lowlevel/tracker.yaml` is read, never written);
`reversals.py` (how often it falls under reversing commands: measured by `mapush probe reversals`, not yet fitted);
`squeeze.py` (whether it falls squeezed between the object and its teammates: `mapush probe squeeze`).
"""
