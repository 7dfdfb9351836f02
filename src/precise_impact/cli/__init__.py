"""The ``precise-impact`` command (also ``python -m precise_impact``)."""

from precise_impact.cli.main import main

__all__ = ["main"]
