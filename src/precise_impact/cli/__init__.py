"""The ``precise-impact`` command (also ``python -m precise_impact``).

The console script enters through :func:`precise_impact.cli.entry.run`, which takes signals
before the heavy imports; ``main`` is loaded on first use so that entry stays light."""

from __future__ import annotations

from typing import Any

__all__ = ["main"]


def __getattr__(name: str) -> Any:
    if name == "main":
        from precise_impact.cli.main import main  # noqa: PLC0415 -- start-up: loaded when the command runs

        return main
    raise AttributeError(f"module 'precise_impact.cli' has no attribute {name!r}")
