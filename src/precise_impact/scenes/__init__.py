"""Scenes: TOML descriptions of one simulation (system, model, effects, parameters, precision, duration).

* :mod:`~precise_impact.scenes.scene` — :class:`Scene`, :func:`load_scene`, :func:`builtin_scenes`.
* :mod:`~precise_impact.scenes.run` — :func:`run_scene` on the scene's model or another one.

The built-in scenes are the ``*.toml`` files of this package.
"""

from precise_impact.scenes.run import run_scene
from precise_impact.scenes.scene import Scene, builtin_scenes, load_scene

__all__ = ["Scene", "builtin_scenes", "load_scene", "run_scene"]
