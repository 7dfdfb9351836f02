"""Work priced before it starts (issue 35 item 6): the commands that take a grid, a count of
events or points refuse a request over ``--max-time`` or half the machine's memory with exit 3
and one line naming the estimate and the flag, fast and without allocating the grid."""

from __future__ import annotations

import time
import tracemalloc

import pytest

from precise_impact.cli.main import main


def _refused(argv, capsys):
    """Run ``argv``; its status, its stderr, the seconds and the peak traced bytes."""
    tracemalloc.start()
    t = time.perf_counter()
    try:
        rc = main(argv)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return rc, capsys.readouterr().err.strip(), time.perf_counter() - t, peak


@pytest.mark.parametrize(
    ("argv", "names"),
    [
        # the 10^10-point map: ~2.5 TB of arrays, refused on memory, naming the grid
        (
            ["basins", "--eta", "0.74", "--phase", "0", "1", "100000", "--v", "0", "3", "100000"],
            ("grid points", "10000000000 points", "TB"),
        ),
        # 10^6 points x 248 periods x 10 us = 2480 s: over a 600 s budget
        (
            [
                "basins",
                "--eta",
                "0.74",
                "--phase",
                "0",
                "1",
                "1000",
                "--v",
                "0",
                "3",
                "1000",
                "--max-time",
                "600",
            ],
            ("--max-time", "1000000 points", "41.3 min"),
        ),  # fmt: skip
        # 10^6 closed-form events x 50 ms = 13.9 h, over the default hour
        (
            ["impact-map", "--eta", "0.74", "--n", "1000000", "--engine", "closed-form"],
            ("--max-time", "1000000 events on closed-form", "13.9 h"),
        ),
        # 10^6 orbit events x 20 us (the compiled impact map) under the set (1300 points x 3.5 ms
        # + 5 s): 29.6 s, over 10 s
        (
            ["singularity", "--eta", "0.74", "--orbit", "1000000", "--max-time", "10"],
            ("--max-time", "1000000 orbit events", "~30 s"),
        ),
        # 2 x 100000 points x 40 ms = 2.22 h
        (
            [
                "response",
                "--param",
                "x_w",
                "-2",
                "0.5",
                "--at",
                "-1",
                "--zeta",
                "0",
                "--a",
                "1",
                "--R",
                "0.8",
                "--eta",
                "2.8",
                "--max-points",
                "100000",
            ],
            ("--max-time", "2 x 100000 points", "2.22 h"),
        ),  # fmt: skip
    ],
)
def test_huge_request_refused_before_any_work(argv, names, capsys, tmp_path):
    rc, err, seconds, peak = _refused([*argv, "--out", str(tmp_path / "o")], capsys)
    assert rc == 3, err
    assert len(err.splitlines()) == 1 and err.startswith("precise-impact: over budget:"), err
    for name in names:
        assert name in err, (name, err)
    assert seconds < 5, seconds
    assert peak < 50e6, peak  # nothing of the grid's or the record's size
    assert not any((tmp_path / "o").glob("*/*"))  # no tile, no result written


def test_budget_refused_before_any_work(capsys, tmp_path):
    # 100000 Monte Carlo + 65536 x (2 parts + 2) Sobol draws at ~1 ms a landmark evaluation
    rc, err, seconds, peak = _refused(
        ["budget", "--mc", "100000", "--sobol", "65536", "--out", str(tmp_path / "o")], capsys
    )
    assert rc == 3, err
    assert len(err.splitlines()) == 1 and "--max-time" in err and "100000 Monte Carlo" in err
    assert seconds < 5 and peak < 50e6, (seconds, peak)


def test_spice_score_refused_before_ngspice(capsys, tmp_path):
    # 1 s in steps of 1 ns: 1e9 time points x 30 us (NGSPICE_SECONDS_PER_POINT) = 8.3 h
    cir = tmp_path / "rc.cir"
    cir.write_text("* rc\nV1 in 0 SIN(0 1 1k)\nR1 in out 1k\nC1 out 0 100n\n.tran 1n 1\n.end\n")
    rc, err, seconds, peak = _refused(
        [
            "spice",
            "score",
            str(cir),
            "--x-node",
            "out",
            "--v-node",
            "in",
            "--scene",
            "fig6-period3-ideal",
        ],
        capsys,
    )
    assert rc == 3, err
    assert len(err.splitlines()) == 1 and "--max-time" in err and "1e+09 time points" in err
    assert seconds < 5 and peak < 50e6, (seconds, peak)


def test_capture_bifurcation_refused_before_reading_a_capture(capsys, tmp_path, monkeypatch):
    """Issue 35 item 6: ``capture bifurcation`` priced its computed diagram only after reading and
    analysing every capture.  Now the captures' bytes (1 us each, measured 0.48) and the diagram
    (run_cost of 2000 eta values x 500 periods: ~14 s) are priced first: over a 5 s budget it
    is refused before any capture is read (read_capture is never called)."""
    import precise_impact.lab.scope_files as scope_files

    cap = tmp_path / "c.csv"
    cap.write_bytes(b"x" * 3_000_000)  # its size is all the pricing reads
    read = []
    monkeypatch.setattr(scope_files, "read_capture", lambda *a, **k: read.append(a))
    argv = ["capture", "bifurcation", str(cap), "--computed", "2000", "--max-time", "5"]
    rc, err, took, peak = _refused(argv, capsys)
    assert rc == 3 and len(err.splitlines()) == 1, err
    assert "--max-time" in err and "2000 computed eta values" in err and "3 MB" in err, err
    assert read == [] and took < 5 and peak < 50e6
