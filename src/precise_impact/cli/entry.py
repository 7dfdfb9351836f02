"""The process entry of ``precise-impact`` and ``python -m precise_impact``: a signal at any
moment once the package is imported ends the process with one line and exit 130, never a
traceback or a kill (imports, numba compilations, finalizers, teardown: :func:`interrupt`,
:func:`_leave`).  Why each case and what was measured: ``docs/guide/cli.rst``, "Interrupts and
signals".
"""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import sys
import threading
from collections.abc import Iterator

from precise_impact.signals import recheck_later

#: The exit status of an interrupted run: 128 + SIGINT, the shell's convention.
EXIT_INTERRUPTED = 130


#: Signals noted inside an import and not yet raised (see :func:`interrupt`).
_deferred: list[int] = []


def interrupt(signum, frame) -> None:
    """The run's handler for SIGINT and SIGTERM (and SIGALRM, its re-check): raise
    ``KeyboardInterrupt``, unless the main thread is inside an import. An exception raised in
    a module's body half-way through leaves the module half-initialised, and raised inside a
    class body it is re-raised as a ``RuntimeError`` (``__set_name__``), not an interrupt. There
    the signal is noted and looked at again every
    :data:`~precise_impact.signals.RECHECK_S` seconds (a one-shot real-time timer, SIGALRM,
    :func:`~precise_impact.signals.recheck_later`) until the import is done; then raised."""
    if signum != getattr(signal, "SIGALRM", None):
        _deferred.append(signum)
    elif not _deferred:  # a timer armed by someone else's code: not ours to act on
        return
    if recheck_later(frame):
        return
    _deferred.clear()
    raise KeyboardInterrupt


def _handled() -> tuple[signal.Signals, ...]:
    alarm = (signal.SIGALRM,) if hasattr(signal, "SIGALRM") else ()
    return (signal.SIGINT, signal.SIGTERM, *alarm)


@contextlib.contextmanager
def interrupts() -> Iterator[None]:
    """Ctrl-C and SIGTERM raise ``KeyboardInterrupt`` (never inside an import, see
    :func:`interrupt`) while the block runs; the previous handlers come back after it. An
    interrupt still waiting for its import to end then goes to the previous SIGINT handler.
    Only in the main thread (elsewhere a no-op: Python runs handlers in the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = {sig: signal.getsignal(sig) for sig in _handled()}
    # a signal noted before the block (in build_parser's imports) stays noted: cleared here,
    # its re-check found nothing to raise and the run went on (exit 0 after a SIGINT)
    for sig in before:
        signal.signal(sig, interrupt)
    try:
        yield
    finally:
        if hasattr(signal, "setitimer"):
            signal.setitimer(signal.ITIMER_REAL, 0)
        for sig, handler in before.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)
        if _deferred:  # noted inside an import, never raised: handed on, not lost
            _deferred.clear()
            signal.raise_signal(signal.SIGINT)


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass


def _exit_now(signum, frame):  # pragma: no cover - runs in a subprocess (tests/test_interrupts)
    _flush()
    os.write(2, b"precise-impact: interrupted after the run ended; its results are kept\n")
    os._exit(EXIT_INTERRUPTED)


def _compiling() -> bool:
    """Whether an interrupt left numba compiling a kernel in a helper thread
    (:func:`precise_impact.solvers.fast.control.run_kernel`); never imports the engine."""
    control = sys.modules.get("precise_impact.solvers.fast.control")
    return control is not None and control.compiling()


def _leave(status: int) -> None:  # pragma: no cover - runs in a subprocess
    """End the process now, with ``status``, what was printed flushed: the interpreter's
    teardown would wait for the compilation (~30 s) or meet its lock half-way."""
    _flush()
    os._exit(status)


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
    from precise_impact.cli.main import main  # noqa: PLC0415 -- start-up: imported once signals are taken

    if noted:
        print("precise-impact: interrupted before the run started", file=sys.stderr)
        sys.exit(EXIT_INTERRUPTED)
    for sig in _handled():  # SIGTERM ends a run as Ctrl-C does
        signal.signal(sig, interrupt)
    try:
        try:
            status = main()
        except KeyboardInterrupt:  # outside main()'s own handling: before it, or in its return
            print("precise-impact: interrupted; finished results are kept", file=sys.stderr)
            status = EXIT_INTERRUPTED
        # main() has returned: its results are written. Until the last exit hook, the
        # interpreter joins threads and pools (where an interrupted pool could wait on a
        # worker): a signal there ends the process at once.
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, _exit_now)
        if _compiling():
            _leave(status)
    except KeyboardInterrupt:  # in the few bytecodes between main()'s return and the line above
        _exit_now(signal.SIGINT, None)
    sys.exit(status)
