"""Scenes: TOML descriptions of one simulation; the built-in ones are this package's ``*.toml``."""

from precise_impact.scenes.run import run_scene
from precise_impact.scenes.scene import Scene, builtin_scenes, load_scene

__all__ = ["Scene", "builtin_scenes", "load_scene", "run_scene"]
