"""The process entry of ``precise-impact`` and ``python -m precise_impact``: a signal at any
moment once the package is imported ends the process with one line and exit 130 (or, in the
last teardown step, is ignored), never a traceback or a kill.

:func:`~precise_impact.cli.main.main` handles Ctrl-C and SIGTERM while it works; this wrapper
covers the moments it cannot: the command line's imports (heyoka, numba's glue: ~0.3 s; a
signal there is noted and ends the process once they are done: raised inside an extension's
initialisation it became "ImportError: initialization failed") and the interpreter's teardown
after ``main`` has returned (pools joined, buffers flushed), where a signal killed the process
with status -2/-15 after its results were written. After ``main`` a signal flushes what was
printed and ends the process at once (``os._exit``): the results are complete files by then
(atomic writes), and a teardown that waits on something is not made to wait longer.

Not covered: the ~0.4 s in which ``import precise_impact`` itself runs, before this module is
reached (Python's default: a KeyboardInterrupt traceback, or a kill by SIGTERM); no work has
started then.
"""

from __future__ import annotations

import atexit
import os
import signal
import sys

#: The exit status of an interrupted run: 128 + SIGINT, the shell's convention.
EXIT_INTERRUPTED = 130


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt


def _exit_now(signum, frame):  # pragma: no cover - runs in a subprocess (tests/test_interrupts)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os.write(2, b"precise-impact: interrupted after the run ended; its results are kept\n")
    os._exit(EXIT_INTERRUPTED)


def _ignore_signals() -> None:  # pragma: no cover - runs in a subprocess
    """The last exit hook: from here on only modules are freed and C++ destructors run (no
    work, no joins). CPython puts every Python-level handler back to the default as it
    finalises (and a default SIGINT/SIGTERM kills with status -2/-15), but leaves an ignored
    signal ignored, in every thread (heyoka's and numba's threads included)."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)


def run() -> None:
    """Run the command line and exit with its status (the console script's target)."""
    atexit.register(_ignore_signals)  # registered first, so it runs last
    # During the imports a signal is noted, not raised: an exception inside an extension
    # module's initialisation (heyoka's, numpy's) surfaces as "ImportError: initialization
    # failed" with a traceback (seen once with a SIGINT 1.7 s into a loaded machine's start).
    noted: list[int] = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: noted.append(signum))
    from precise_impact.cli.main import main

    if noted:
        print("precise-impact: interrupted before the run started", file=sys.stderr)
        sys.exit(EXIT_INTERRUPTED)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _raise_interrupt)  # SIGTERM ends a run as Ctrl-C does
    try:
        status = main()
    except KeyboardInterrupt:  # before main() took over its signals: nothing had started
        print("precise-impact: interrupted before the run started", file=sys.stderr)
        status = EXIT_INTERRUPTED
    # main() has returned: its results are written. Until the last exit hook, the interpreter
    # joins threads and pools (where an interrupted pool could wait on a worker): a signal there
    # ends the process at once.
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _exit_now)
    sys.exit(status)
