"""Generic input/output: atomic writes, one writer per directory, figures, progress.

Imports nothing from the package but :mod:`precise_impact.errors`, so every layer may use it.
"""

from precise_impact.io.atomic import atomic_write
from precise_impact.io.figures import new_figure, save_figure
from precise_impact.io.lock import DirectoryLock
from precise_impact.io.progress import Progress, say

__all__ = ["atomic_write", "DirectoryLock", "new_figure", "save_figure", "Progress", "say"]
