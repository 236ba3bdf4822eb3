"""Subcommands of the `filmcal` command line, one module each (see `filmcal.cli`)."""
