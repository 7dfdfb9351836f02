"""Where a signal handler may raise (not in an import, a finalizer, a fork or llvmlite's bindings):
the entry's handler and the pool workers'; ``docs/guide/cli.rst``, "Interrupts and signals"."""

from __future__ import annotations

import signal
from types import CodeType, FrameType

__all__ = ["RECHECK_S", "unsafe_to_raise", "recheck_later"]

#: How often an interrupt that landed where it may not be raised looks again.
RECHECK_S = 0.01

_IMPORT_FRAMES = frozenset(
    {"<frozen importlib._bootstrap>", "<frozen importlib._bootstrap_external>"}
)
#: Where an exception raised by the handler is printed and dropped ("Exception ignored in"),
#: and the interrupt lost: a finalizer, the fork of a pool's worker (logging's at-fork
#: hooks: a fast sweep ran on after SIGTERM), and llvmlite's object-cache callbacks, which
#: LLVM calls through ctypes as numba compiles in the main thread (``continue`` ran on for
#: 60 s after a SIGTERM there).  Function names; file name endings.
_DROPPING_FUNCTIONS = frozenset({"__del__"})
_DROPPING_FILES = (
    "multiprocessing/popen_fork.py",
    "multiprocessing/popen_forkserver.py",
    "llvmlite/binding/executionengine.py",
    # weak-reference callbacks (a SIGTERM in WeakSet's _remove printed "Exception ignored"
    # with a traceback: 1 of 10 sweep signals in CI)
    "/_weakrefset.py",
    "/weakref.py",
)
#: Directories whose Python code is let finish before an interrupt: llvmlite's bindings build
#: objects whose finalizer needs all their fields (a SIGTERM between two of
#: ``ObjectRef.__init__``'s assignments printed "Exception ignored in ObjectRef.__del__" with
#: a traceback, 1 of 90 slow-run signals); their Python steps take microseconds.
_DEFERRING_DIRS = ("/llvmlite/binding/",)


def unsafe_to_raise(frame: FrameType | None, below: CodeType | None = None) -> bool:
    """Whether ``frame`` runs inside an import (the import machinery is on its stack: also its
    module-lock callbacks, where a pool worker's interrupt printed "Exception ignored in
    _get_module_lock.<locals>.cb", 1 of 40 SIGTERMs to ``bifurcation``), a finalizer, a fork or
    llvmlite's bindings.  ``below``: the stack is looked at down to the frame of this code
    only (a forked pool worker's whole stack stands on ``popen_fork``'s launch: looked at to
    the bottom, every moment of it was "inside a fork" and its interrupts waited for ever)."""
    while frame is not None:
        code = frame.f_code
        if code is below:
            return False
        if (
            code.co_filename in _IMPORT_FRAMES
            or code.co_name in _DROPPING_FUNCTIONS
            or code.co_filename.endswith(_DROPPING_FILES)
            or any(d in code.co_filename for d in _DEFERRING_DIRS)
        ):
            return True
        frame = frame.f_back
    return False


def recheck_later(frame: FrameType | None, below: CodeType | None = None) -> bool:
    """If ``frame`` may not raise (:func:`unsafe_to_raise`, down to ``below``): arm a one-shot
    real-time timer (SIGALRM in :data:`RECHECK_S`, whose handler must be the caller's own) and
    return True; else False."""
    if unsafe_to_raise(frame, below) and hasattr(signal, "setitimer"):
        signal.setitimer(signal.ITIMER_REAL, RECHECK_S)
        return True
    return False
