"""What the simple commands do, apart from their command-line parsing (`mapush.cli`): train, ship, plan, plot.
Each module sits at its own layer (pyproject.toml, import-linter): `train` below the experiments that run it,
`ship` beside them, `plot` beside the report, `plan` beside the RL layer."""
