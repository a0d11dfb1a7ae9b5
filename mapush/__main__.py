"""`python -m mapush ...` is the `mapush` command."""

from mapush.cli import main

main()
