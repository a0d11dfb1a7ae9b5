"""MCAP logs: training scalars through an rsl-rl LogWriter (the MCAP issue adds episode scenes and recovery)."""
