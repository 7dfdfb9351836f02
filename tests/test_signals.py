"""Where an interrupt may be raised (``signals.py``) and the pool worker's handler that uses it
(``analysis/scan._worker_sigint``): a SIGINT inside the import machinery (a module lock's
callback printed "Exception ignored in _get_module_lock.<locals>.cb", 1 of 40 slow-run
SIGTERMs to ``bifurcation``) waits for a re-check instead of raising there."""

from __future__ import annotations

import signal
import sys

import pytest

from precise_impact import signals
from precise_impact.analysis import scan

pytestmark = pytest.mark.skipif(not hasattr(signal, "setitimer"), reason="POSIX timers")


def _in(filename: str, name: str = "f"):
    """A function whose frame carries ``filename``: called with a handler, it calls the handler
    from that frame, as a signal landing there would."""
    src = f"def {name}(handler, signum):\n    return handler(signum, sys._getframe())\n"
    ns = {"sys": sys}
    exec(compile(src, filename, "exec"), ns)  # noqa: S102 -- a frame with this file name
    return ns[name]


@pytest.mark.parametrize(
    "filename,name,unsafe",
    [
        ("<frozen importlib._bootstrap>", "f", True),
        ("/x/multiprocessing/popen_fork.py", "f", True),
        ("/x/site-packages/llvmlite/binding/ffi.py", "f", True),
        ("/x/anything.py", "__del__", True),
        ("/usr/lib/python3.11/_weakrefset.py", "_remove", True),
        ("/x/precise_impact/solvers/fast/single.py", "f", False),
    ],
)
def test_unsafe_frames(filename, name, unsafe):
    f = _in(filename, name)
    assert f(lambda _s, frame: signals.unsafe_to_raise(frame), 0) is unsafe


@pytest.fixture
def busy_worker(monkeypatch):
    monkeypatch.setattr(scan, "_BUSY", True)
    monkeypatch.setattr(scan, "_STOPPED", False)
    before = signal.getsignal(signal.SIGALRM)
    signal.signal(signal.SIGALRM, lambda *_: None)
    yield
    signal.setitimer(signal.ITIMER_REAL, 0)
    signal.signal(signal.SIGALRM, before)


def test_a_workers_interrupt_inside_an_import_waits_for_a_recheck(busy_worker):
    f = _in("<frozen importlib._bootstrap>")
    f(scan._worker_sigint, signal.SIGINT)  # no KeyboardInterrupt here
    assert scan._STOPPED and signal.getitimer(signal.ITIMER_REAL)[0] > 0
    signal.setitimer(signal.ITIMER_REAL, 0)
    g = _in("/x/precise_impact/analysis/scan.py")
    with pytest.raises(KeyboardInterrupt):  # the re-check, out of the import: raised
        g(scan._worker_sigint, signal.SIGALRM)


def test_a_workers_interrupt_in_its_tile_is_raised_at_once(busy_worker):
    g = _in("/x/precise_impact/solvers/fast/single.py")
    with pytest.raises(KeyboardInterrupt):
        g(scan._worker_sigint, signal.SIGINT)


def test_an_idle_worker_notes_the_interrupt_and_goes_on(busy_worker, monkeypatch):
    monkeypatch.setattr(scan, "_BUSY", False)
    _in("/x/y.py")(scan._worker_sigint, signal.SIGINT)
    assert scan._STOPPED
    _in("/x/y.py")(scan._worker_sigint, signal.SIGALRM)  # someone else's timer: nothing


def _calls(filename: str):
    """A function whose frame carries ``filename`` and that calls ``fn(*args)``."""
    ns: dict = {}
    exec(compile("def call(fn, *args):\n    return fn(*args)\n", filename, "exec"), ns)  # noqa: S102
    return ns["call"]


def test_a_forked_workers_tile_is_interrupted_at_once(busy_worker, monkeypatch):
    """A forked pool worker's whole stack stands on multiprocessing's popen_fork (where the
    process entry defers): the worker looks only above its tile's frame, so an interrupt in a
    tile is raised at once (it waited for ever: a 3 s interrupt of a sweep took 55 s)."""
    monkeypatch.setattr(scan, "_STOPPED", False)
    monkeypatch.setattr(scan, "_BUSY", False)

    def tile(lo, hi):
        return _in("/x/precise_impact/solvers/fast/control.py")(scan._worker_sigint, signal.SIGINT)

    launch = _calls("/usr/lib/python3.11/multiprocessing/popen_fork.py")
    with pytest.raises(KeyboardInterrupt):
        launch(scan._in_worker, tile, 0, 1)
    assert signal.getitimer(signal.ITIMER_REAL)[0] == 0  # nothing deferred


def test_below_limits_the_frames_looked_at():
    launch = _calls("/x/multiprocessing/popen_fork.py")
    middle = _calls("/x/precise_impact/analysis/scan.py")

    def look():
        return signals.unsafe_to_raise(sys._getframe(), below=middle.__code__)

    assert launch(middle, look) is False
    assert launch(middle, lambda: signals.unsafe_to_raise(sys._getframe())) is True
