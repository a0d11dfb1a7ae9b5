"""What every `mapush` command does, apart from reading its command line (`mapush.cli`, the Typer surface): one
module per cli module (run_commands for cli/runs.py, experiment_commands, log_commands, probe_commands,
tool_commands), the arguments they share (arguments.py) and the bigger bodies of ship, plan and plot. The package
sits in the layer just under the cli (pyproject.toml, import-linter); modules import torch and MuJoCo only inside
functions, so that `mapush --help` stays light."""
