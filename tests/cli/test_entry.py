"""The process entry (cli/entry.run): a signal during the command line's imports is noted and
ends the process with one line and exit 130 once they are done, never an ImportError traceback
(raised inside an extension's initialisation, a SIGINT became "ImportError: initialization
failed", exit 1, seen once on a loaded machine). The signal is sent from an import hook at the
moment ``precise_impact.cli.main`` starts loading, so the case is exact, not a race."""

from __future__ import annotations

import signal
import subprocess
import sys

import pytest

PROGRAM = """
import os, signal, sys
import precise_impact.cli.entry as entry

class SignalOnImport:
    def find_spec(self, name, path, target=None):
        if name == "precise_impact.cli.main":
            os.kill(os.getpid(), signal.{sig})
        return None

sys.meta_path.insert(0, SignalOnImport())
sys.argv = ["precise-impact", "--version"]
entry.run()
"""


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_a_signal_during_the_imports_is_one_line_and_exit_130(sig):
    r = subprocess.run(
        [sys.executable, "-c", PROGRAM.format(sig=sig)],
        capture_output=True,
        text=True,
        timeout=120,
        # a default SIGINT disposition even when the test runner ignores it
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.default_int_handler),
    )
    assert r.returncode == 130, (r.returncode, r.stderr[-800:])
    assert "Traceback" not in r.stderr, r.stderr[-800:]
    assert r.stderr.strip().splitlines() == ["precise-impact: interrupted before the run started"]
    assert r.stdout == ""  # --version was not run: the signal came first


def test_without_a_signal_the_entry_runs_the_command():
    r = subprocess.run(
        [
            sys.executable,
            "-c",
            PROGRAM.replace("os.kill", "(lambda *a: None)").format(sig="SIGINT"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr[-800:]
    assert r.stdout.startswith("precise-impact ")
