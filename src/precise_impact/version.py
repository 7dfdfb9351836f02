"""The installed version, read once from the package metadata (written once, in
``pyproject.toml``)."""

from importlib import metadata as _metadata

try:
    __version__ = _metadata.version("precise_impact")
except _metadata.PackageNotFoundError:  # pragma: no cover - a source tree that is not installed
    __version__ = "0+unknown"

__all__ = ["__version__"]
