"""rsl-rl glue: the env x agent row adapter, runner construction, checkpoints, resume and export."""
