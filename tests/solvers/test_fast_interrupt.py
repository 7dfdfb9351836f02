"""Ctrl-C and SIGTERM stop the fast engine's compiled loops cleanly (issue 28).

Before: a signal during ``lle --model fast`` ended in a segmentation fault (exit 139) or a
``SystemError`` ("returned a result with an exception set": the pending interrupt raised while
the kernel's results were boxed), and only once the whole kernel had finished; a fast sweep on
one worker printed that traceback.  Now the kernels poll a stop flag (every
``POLL_PERIODS`` periods) set from the main thread, which waits in Python: exit 130 with one
line within a second, finished tiles intact and resumable.
"""

from __future__ import annotations

import _thread
import os
import queue
import random
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("numba")

from precise_impact import Params  # noqa: E402
from precise_impact.analysis.scan import NpzTileStore, run_scan  # noqa: E402
from precise_impact.analysis.sweep import SweepSpec, compute_tile, run_sweep  # noqa: E402
from precise_impact.errors import Interrupted  # noqa: E402
from precise_impact.solvers.fast.control import (  # noqa: E402
    STATUS_INTERRUPTED,
    STOP_ABORT,
    STOP_INTERRUPT,
    new_flag,
)
from precise_impact.solvers.fast.lle import (  # noqa: E402
    LLE_KERNELS,
    batch_outputs,
    kernel_inputs,
    lle_batch,
)
from precise_impact.solvers.fast.single import STATUS_OK  # noqa: E402

SRC = str(Path(__file__).resolve().parents[2] / "src")
#: Seconds from the signal to the exit: the kernel stops within POLL_PERIODS periods (~1 ms),
#: then the interpreter shuts down (0.3-2.1 s measured); 9.1 s was seen once with both cores
#: taken by other test runs (the parallel kernel's threads compete for them): 20 s bounds it
#: and still tells a clean stop from the old crash or a run to the end (minutes). 25.5 s was
#: seen at a load average of 7 on 2 cores: a process given a fraction of a core takes that much
#: longer to wind down, so the bound scales with the load per core when it exceeds one.
EXIT_BOUND = 20.0 * max(1.0, os.getloadavg()[0] / (os.cpu_count() or 1))


def _outputs(n, blocks=2, keep=1):
    return batch_outputs(n, blocks, keep)


@pytest.mark.parametrize("parallel", [True, False])
def test_a_set_stop_flag_stops_every_orbit_before_its_first_period(parallel):
    pars, starts = kernel_inputs(Params.make(), 3)
    out, counts, stop = _outputs(3), np.zeros(3, np.int64), new_flag()
    stop[0] = STOP_INTERRUPT
    LLE_KERNELS[parallel](pars, starts, 10**6, 0, 2, 10**8, False, *out, stop, counts)
    assert list(out[0]) == [STATUS_INTERRUPTED] * 3 and list(counts) == [0, 0, 0]
    stop[0] = 0  # the same call runs to the end and publishes every period
    LLE_KERNELS[parallel](pars, starts, 100, 20, 2, 10**8, False, *out, stop, counts)
    assert list(out[0]) == [STATUS_OK] * 3 and list(counts) == [120] * 3


def test_an_unresolved_orbit_stops_the_batch_only_when_asked():
    """abort_on_failure: the first orbit's impact budget (1 impact) runs out at once and the
    others stop (they would go to the fallback engine with it); without it they run on."""
    pars, starts = kernel_inputs(Params.make(), 2)
    starts = starts.copy()
    out, counts, stop = _outputs(2), np.zeros(2, np.int64), new_flag()
    # max_impacts = 1 for both: each stops at its first impact, whichever comes first
    LLE_KERNELS[False](pars, starts, 10**6, 0, 2, 1, True, *out, stop, counts)
    assert stop[0] == STOP_ABORT and out[0][0] != STATUS_OK
    assert out[0][1] == STATUS_INTERRUPTED and counts[1] == 0  # never started its loop
    out, counts, stop = _outputs(2), np.zeros(2, np.int64), new_flag()
    LLE_KERNELS[False](pars, starts, 10**6, 0, 2, 1, False, *out, stop, counts)
    assert stop[0] == 0 and STATUS_INTERRUPTED not in out[0]


@pytest.fixture
def python_sigint_handler():
    """These tests deliver Ctrl-C with ``_thread.interrupt_main()``, which does nothing unless
    SIGINT has Python's default handler (CPython: an ignored or default-action signal is not
    simulated).  In CI's serial run over the installed package both tests saw their interrupt
    vanish ("DID NOT RAISE") after the earlier tests although no test boundary showed another
    handler in a checkout run: the premise is set here, and a handler found in its place is
    printed (pytest -rA shows it) to find who leaves it."""
    found = signal.getsignal(signal.SIGINT)
    if found is not signal.default_int_handler:
        print(f"SIGINT handler before the test: {found!r}")
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield found
    finally:
        signal.signal(signal.SIGINT, found)


@pytest.mark.usefixtures("python_sigint_handler")
def test_an_interrupt_stops_a_long_compiled_run_within_a_second():
    """interrupt_main() is a SIGINT as the main thread sees it: the 4 x 10^8-period run (minutes)
    stops at once with its partial sums, the numbers of the periods done."""
    pars, starts = kernel_inputs(Params.make(eta="0.712"), 4)
    lle_batch(pars, starts, 10, 0, 2, 10**8, 1)  # compiled / loaded
    timer = threading.Timer(0.5, _thread.interrupt_main)
    t0 = time.monotonic()
    timer.start()
    with pytest.raises(Interrupted, match=r"interrupted after \d+ of 100000000 periods") as e:
        lle_batch(pars, starts, 10**8, 0, 2, 10**9, 1)
    took = time.monotonic() - t0
    timer.join()
    assert took < 0.5 + 1.0, took
    status, log1 = e.value.partial[0], e.value.partial[1]
    assert list(status) == [STATUS_INTERRUPTED] * 4 and np.all(np.isfinite(log1))


def _long_tile(lo, hi):
    """A tile of ~20 s: one orbit of 3e7 periods on the compiled kernel (eta = 0.8: period 1)."""
    pars, starts = kernel_inputs(Params.make(eta="0.8"), 1)
    lle_batch(pars, starts, 3 * 10**7, 0, 2, 10**9, 1, parallel=False)
    return lo


@pytest.mark.usefixtures("python_sigint_handler")
def test_an_interrupt_stops_the_tiles_of_worker_processes():
    """An interrupt reaching the parent alone (SIGTERM from a scheduler, here interrupt_main)
    waited for every tile running or queued in the pool to finish (tile 2048 of a 100 x 100
    sweep: exit 50.7 s after SIGTERM); now the workers are interrupted too and refuse their
    queued tiles (0.5 s).  A real SIGINT to the main thread: interrupt_main() would not wake
    the parent from its wait for the pool."""
    main = threading.main_thread().ident
    timer = threading.Timer(3.0, signal.pthread_kill, (main, signal.SIGINT))
    t0 = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        run_scan(_long_tile, 6, 1, executor="processes", workers=2, progress=False)
    took = time.monotonic() - t0
    timer.join()
    assert took < 3.0 + 2.0, took


class _Run:
    """A CLI run in a subprocess whose stderr is read line by line as it comes."""

    def __init__(self, *args, env=None):
        self.p = subprocess.Popen(
            [sys.executable, "-m", "precise_impact", *args],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            env=dict(os.environ, PYTHONPATH=SRC, **(env or {})),
            # a default SIGINT disposition even when the test runner ignores it
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.default_int_handler),
        )
        self.lines: queue.Queue = queue.Queue()
        self.err: list[str] = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self):
        for line in self.p.stderr:
            self.err.append(line)
            self.lines.put(line)
        self.lines.put(None)

    def wait_for(self, marker: str, timeout: float = 60) -> None:
        """Until a line of stderr contains ``marker`` (the run is under way)."""
        end = time.monotonic() + timeout
        while True:
            try:
                line = self.lines.get(timeout=max(end - time.monotonic(), 0.01))
            except queue.Empty:
                self.p.kill()
                raise AssertionError(f"no {marker!r} on stderr within {timeout} s") from None
            if line is None:
                raise AssertionError(f"exited without {marker!r}: {''.join(self.err)[-800:]}")
            if marker in line:
                return

    def stop(self, sig, delay: float = 0.0) -> tuple[float, str]:
        """Send ``sig`` after ``delay`` s; the seconds until the exit and the whole stderr."""
        time.sleep(delay)
        t0 = time.monotonic()
        self.p.send_signal(sig)
        try:
            self.p.wait(timeout=60)
        finally:
            self.p.kill()
        took = time.monotonic() - t0
        self.reader.join(10)
        return took, "".join(self.err)


def _lle_interrupted(sig, delay):
    # 4 x 2.5e7 periods: ~1 min of the compiled kernel; the first progress line comes at 2 s.
    # eta = 0.8: a period-1 attractor, one impact a period, never a tangential contact (the
    # chaotic eta = 0.712 meets one within seconds, and the estimate goes to heyoka)
    run = _Run(
        "lle", "--model", "fast", "--eta", "0.8", "--periods", "100000000", "--max-time", "100000"
    )
    run.wait_for("lle periods")
    took, err = run.stop(sig, delay)
    p = run.p
    lines = [ln for ln in err.strip().splitlines() if not ln.lstrip().startswith("lle periods")]
    assert p.returncode == 130, err[-800:]
    assert "Traceback" not in err and "Error" not in err, err[-800:]
    assert len(lines) == 1 and lines[0].startswith("precise-impact: interrupted after "), lines
    assert took < EXIT_BOUND, took
    return took


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_lle_fast_stops_on_a_signal_with_exit_130(sig):
    _lle_interrupted(sig, 0.0)


def test_a_signal_during_the_kernels_compilation_exits_at_once(tmp_path):
    """On a fresh install numba compiles the kernel (~30 s) when the run starts; the
    compilation ran in the kernel's helper thread and a SIGTERM then waited for it (CI: exit
    26.7 s after the signal).  Now it compiles in the main thread, where the signal is raised
    between two of the compiler's Python steps.  A fresh numba cache makes the install fresh;
    the first file in it says the compilation is under way."""
    cache = tmp_path / "numba"
    cache.mkdir()
    run = _Run(
        "lle", "--model", "fast", "--eta", "0.8", "--periods", "1000000",
        env={"NUMBA_CACHE_DIR": str(cache)},
    )  # fmt: skip
    end = time.monotonic() + 120
    while not any(f.is_file() for f in cache.rglob("*")):
        assert time.monotonic() < end and run.p.poll() is None, "".join(run.err)[-800:]
        time.sleep(0.05)
    took, err = run.stop(signal.SIGTERM)
    assert run.p.returncode == 130, err[-800:]
    # progress lines may precede the one that says what was kept: a compilation slowed past
    # 2 s by a loaded machine printed "lle periods: 0/1004000 (2.1 s)" twice first
    lines = [x for x in err.strip().splitlines() if not x.strip().startswith("lle periods:")]
    assert len(lines) == 1, err[-800:]
    once = r"precise-impact: interrupted after 0 of \d+ periods per start \(4 starts\)"
    assert re.fullmatch(once, lines[0]), lines
    assert took < EXIT_BOUND / 4, took  # 0.8-1.3 s measured


def _sweep_args(out):
    return ["sweep", "--workers", "1", "--tile", "16"] + [
        "--axis",
        "eta",
        "0.6",
        "0.9",
        "40",
        "--axis",
        "x_w",
        "0.1",
        "0.5",
        "8",
        "--out",
        str(out),
    ]


FIELDS = ("lle", "stderr", "lambda2", "period", "impacts_per_period")


def _store(out, spec):
    return NpzTileStore(out, spec.digest, FIELDS, spec.n_points, spec.tile_size)


def _sweep_spec():
    return SweepSpec.make(
        Params.make(), [("eta", "0.6", "0.9", 40), ("x_w", "0.1", "0.5", 8)], tile_size=16
    )


def _interrupt_sweep(out, sig, delay):
    run = _Run(*_sweep_args(out))
    run.wait_for("sweep tiles")  # the first tile is on disk
    took, err = run.stop(sig, delay)
    p = run.p
    assert p.returncode == 130, err[-800:]
    lines = [ln for ln in err.strip().splitlines() if not ln.lstrip().startswith("sweep tiles")]
    assert lines == ["precise-impact: interrupted; finished results are kept"], err[-800:]
    assert took < EXIT_BOUND, took
    spec = _sweep_spec()
    store = _store(out, spec)
    kept = sorted(int(f.stem.split("_")[1]) for f in (out / "tiles").glob("tile_*.npz"))
    assert kept and not list((out / "tiles").glob("*.tmp*"))
    for t in kept:  # every tile on disk verifies: digest, checksum, its own points
        data, why = store.read(t)
        assert data is not None, (t, why)
    return spec, kept, took


def test_an_interrupted_fast_sweep_keeps_whole_tiles(tmp_path):
    """SIGTERM on one worker (the case that printed a SystemError traceback): exit 130, one
    line, and the tiles on disk verify and equal the same tiles computed afresh."""
    out = tmp_path / "s"
    spec, kept, _ = _interrupt_sweep(out, signal.SIGTERM, 0.0)
    store = _store(out, spec)
    t = kept[0]
    data, _ = store.read(t)
    fresh = compute_tile(spec, t)
    for f in FIELDS + ("index",):
        assert np.array_equal(data[f], fresh[f], equal_nan=True), f


@pytest.mark.slow
def test_signals_at_random_moments():
    """Up to ten signals at random moments of a fast sweep (SIGINT and SIGTERM alternately),
    each run resuming the last one's tiles, end in the same numbers as one uninterrupted run.
    (Ten signals at random moments of ``lle --model fast``, most of them inside its compiled
    kernel, are tests/test_interrupts.py's slow tries of lle-fast: this test sent ten more.)"""
    rng = random.Random(28)
    for _ in range(10):  # the moments the lle tries drew before: the sweep's stay the same
        rng.uniform(0.0, 3.0)
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "s"
        for k in range(10):
            sig = signal.SIGINT if k % 2 == 0 else signal.SIGTERM
            if (out / "sweep.npz").exists():
                break
            run = _Run(*_sweep_args(out))
            try:
                run.wait_for("sweep tiles")
            except AssertionError:  # finished before its first progress line: done
                run.p.wait(60)
                break
            _, err = run.stop(sig, rng.uniform(0.0, 1.0))
            assert run.p.returncode in (0, 130), err[-800:]
            assert "Traceback" not in err, err[-800:]
        resumed = run_sweep(_sweep_spec(), out, workers=1, progress=False)
        once = run_sweep(_sweep_spec(), Path(tmp) / "once", workers=1, progress=False)
        assert resumed.complete and once.complete
        for f in FIELDS:
            assert np.array_equal(getattr(resumed, f), getattr(once, f), equal_nan=True), f
