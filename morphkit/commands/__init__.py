"""Subcommands of the ``morphkit`` CLI (one module each; see :mod:`morphkit.cli`)."""
