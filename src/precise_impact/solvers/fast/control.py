"""Stopping and watching the fast engine's compiled loops: a stop flag they poll, a progress
counter they publish, and :func:`run_kernel`, which turns Ctrl-C / SIGTERM into a clean stop
(:class:`~precise_impact.errors.Interrupted` with the work done so far).

How and why (a signal handler cannot run inside a nopython loop): ``docs/design.rst``,
"Engines by arithmetic".
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from precise_impact.errors import Interrupted
from precise_impact.io.progress import Progress, ProgressArg

__all__ = [
    "POLL_PERIODS",
    "STOP_NONE",
    "STOP_INTERRUPT",
    "STOP_ABORT",
    "STATUS_INTERRUPTED",
    "load_flag",
    "store_count",
    "new_flag",
    "run_kernel",
]

#: Periods between two looks at the stop flag (and two progress updates) in a kernel:
#: ~1 ms of work, so a stop is seen within milliseconds and the polling costs nothing.
POLL_PERIODS = 256

#: Values of the stop flag: run on; stop (Ctrl-C, SIGTERM); stop because another orbit of the
#: batch failed and the batch goes to the fallback engine anyway.
STOP_NONE, STOP_INTERRUPT, STOP_ABORT = 0, 1, 2

#: A kernel's status when it stopped on its flag (the other statuses:
#: :mod:`precise_impact.solvers.fast.single`).
STATUS_INTERRUPTED = 6

#: Seconds a run goes before progress is shown (a short run prints nothing).
PROGRESS_AFTER = 2.0
#: Seconds between two looks of the waiting thread at the kernel.
WAIT_INTERVAL = 0.05


def _element_pointer(context, builder, arr_ty, arr, idx):
    ary = context.make_array(arr_ty)(context, builder, arr)
    return cgutils.get_item_pointer(context, builder, arr_ty, ary, [idx], wraparound=False)


@intrinsic
def load_flag(typingctx, arr, idx):
    """``arr[idx]`` (an ``int64`` array) by an atomic load: read anew at every call, never
    hoisted out of a loop."""
    if not (isinstance(arr, types.Array) and arr.dtype == types.int64):
        return None

    def codegen(context, builder, sig, args):
        ptr = _element_pointer(context, builder, sig.args[0], args[0], args[1])
        return builder.load_atomic(ptr, "monotonic", 8)

    return types.int64(arr, types.intp), codegen


@intrinsic
def store_count(typingctx, arr, idx, value):
    """``arr[idx] = value`` (``int64``) by an atomic store: visible to another thread at once."""
    if not (isinstance(arr, types.Array) and arr.dtype == types.int64):
        return None

    def codegen(context, builder, sig, args):
        ptr = _element_pointer(context, builder, sig.args[0], args[0], args[1])
        val = context.cast(builder, args[2], sig.args[2], types.int64)
        builder.store_atomic(val, ptr, "monotonic", 8)
        return context.get_dummy_value()

    return types.void(arr, types.intp, types.int64), codegen


def new_flag() -> np.ndarray:
    """A fresh stop flag (:data:`STOP_NONE`)."""
    return np.zeros(1, np.int64)


#: Helper threads left compiling a kernel by an interrupt (:func:`run_kernel`): the command
#: line ends its process without waiting for them (:mod:`precise_impact.cli.entry`).
_abandoned: list[threading.Thread] = []


def compiling() -> bool:
    """Whether a compilation abandoned by an interrupt still runs in a helper thread."""
    return any(t.is_alive() for t in _abandoned)


def _in_thread(kernel: Any, args: tuple, box: dict, entered: threading.Event) -> None:
    try:
        # the interrupt is the main thread's to take: never this thread's system calls
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
        kernel.compile(tuple(numba.typeof(a) for a in args))  # or loaded from the cache
        entered.set()
        box["value"] = kernel(*args)
    except BaseException as e:  # handed to the waiting thread
        box["error"] = e
    finally:
        entered.set()
        box["done"].set()


def run_kernel(
    kernel: Any,
    args: tuple,
    stop: np.ndarray,
    counts: np.ndarray | None = None,
    total: int = 0,
    progress: ProgressArg = False,
    label: str = "periods",
    what: Callable[[int], str] | None = None,
) -> Any:
    """``kernel(*args)`` (a compiled kernel, ``nogil``, polling ``stop``) so that Ctrl-C and
    SIGTERM stop it cleanly, with progress from ``counts``.

    The kernel is compiled (or loaded from numba's cache) in the helper thread first. A
    compilation takes ~30 s on a fresh install; an interrupt during it does not wait for it
    (it did: exit 27 s after SIGTERM in CI), and cannot stop it (numba's compiler, interrupted
    by an exception, freed its LLVM objects twice: "double free", a crash): the interrupt is
    raised at once, with nothing done, and the compilation finishes in its thread
    (:func:`compiling`).

    Parameters
    ----------
    kernel : numba dispatcher
        The compiled kernel; its result is returned.
    args : tuple
        Its arguments, ``stop`` and ``counts`` among them.
    stop : numpy.ndarray
        The kernel's stop flag (:func:`new_flag`); set to :data:`STOP_INTERRUPT` on an
        interrupt.
    counts : numpy.ndarray or None
        Work done so far, published by the kernel (:func:`store_count`); the progress is
        its sum.
    total : int
        The sum of ``counts`` at the end.
    progress : bool, None or callable
        :data:`~precise_impact.io.progress.ProgressArg`; a line only once the run has gone
        :data:`PROGRESS_AFTER` seconds.
    label : str
        What the progress line counts.
    what : callable or None
        ``what(done)`` says what was finished when interrupted (the
        :class:`~precise_impact.errors.Interrupted` message).

    Returns
    -------
    object
        ``kernel(*args)``'s result.

    Raises
    ------
    Interrupted
        Ctrl-C or SIGTERM while the kernel ran; raised once the kernel has stopped (its
        arrays hold the work done so far).

    Notes
    -----
    Outside the main thread (a test runner's thread, a Dask worker) no signal can reach
    this code: the kernel runs right there (without progress).
    """
    if threading.current_thread() is not threading.main_thread():
        return kernel(*args)
    done, entered = threading.Event(), threading.Event()
    box: dict[str, Any] = {"done": done}
    worker = threading.Thread(target=_in_thread, args=(kernel, args, box, entered), daemon=True)
    bar = Progress(total, label, progress) if counts is not None and total > 0 else None
    start = time.perf_counter()
    interrupt: BaseException | None = None
    worker.start()
    while True:
        try:
            if interrupt is None:
                while not done.wait(WAIT_INTERVAL):
                    if bar is not None and time.perf_counter() - start > PROGRESS_AFTER:
                        bar.update(int(counts.sum()))  # type: ignore[union-attr]
            elif entered.is_set():  # stopping: the kernel sees the flag within POLL_PERIODS periods
                done.wait()
            else:  # still compiling: not waited for
                _abandoned.append(worker)
            break
        except BaseException as e:  # Ctrl-C; SIGTERM arrives as one too (precise_impact.cli.main)
            stop[0] = STOP_INTERRUPT  # (anything else raised here, too: never left running)
            if interrupt is None:
                interrupt = e
    if bar is not None and time.perf_counter() - start > PROGRESS_AFTER:
        bar.update(int(counts.sum()))  # type: ignore[union-attr]
        bar.close()
    if interrupt is not None and not isinstance(interrupt, KeyboardInterrupt):
        raise interrupt
    if "error" in box:
        raise box["error"]
    if interrupt is not None:
        finished = int(counts.sum()) if counts is not None else 0
        text = what(finished) if what is not None else "interrupted"
        raise Interrupted(text, box.get("value")) from interrupt
    return box["value"]
