"""The certified master-slave pair against independent references: heyoka's multiprecision
integration of the pair (another method: Taylor series with event detection on the four-state
system, not the closed form), the single oscillator's certified run (the diagonal), and a
constructed near-simultaneous impact whose order is known exactly."""

import json
import subprocess
import sys
from fractions import Fraction

import pytest

import precise_impact as pi

flint = pytest.importorskip("flint", reason="python-flint: pip install python-flint")
mpmath = pytest.importorskip("mpmath")

from precise_impact.solvers.certified.single import CertificationError, exact_value  # noqa: E402


def _mp(b):
    f = exact_value(b.mid())
    return mpmath.mpf(f.numerator) / f.denominator


@pytest.mark.parametrize("form", ["first-order", "paper", "reduced"])
@pytest.mark.parametrize("k", ["0.1", "0.02"])
def test_pair_contains_heyoka_mp(form, k):
    """60 chaotic periods (eta = 0.712) off the diagonal: equal impact counts of both
    oscillators, and every heyoka mp:256 sample of (x, v, y, w) inside the certified ball
    widened by heyoka's own error.  That error: rounding 2^-256 ~ 1e-77 grown by the chaos,
    10^(0.131 x 60) ~ 1e8, and by ~1e4 steps and impacts: <= 1e-65; 1e-60 is the bound used
    (the balls themselves are measured at 1e-64 .. 1e-61 at 256 bits with the default Lohner
    enclosure, 1e-57 .. 1e-49 with the interval one)."""
    p = pi.Params.make(eta="0.712")
    y0 = ("0.5", "0.1")
    r = pi.certify_coupled(p, k, form, 60, y0=y0, precision="mp:256")
    h = pi.simulate_coupled(p, k, form, 60, y0=y0, precision="mp:256")
    assert len(r.master_impacts) == len(h.master_impacts_t) and len(r.slave_impacts) == len(
        h.slave_impacts_t
    )
    assert r.max_radius() < 1e-45
    with mpmath.workprec(600):
        for i, (_, _, *balls) in enumerate(r.samples):
            for b, hv in zip(balls, (h.x[i], h.v[i], h.y[i], h.w[i]), strict=True):
                assert abs(mpmath.mpf(str(hv)) - _mp(b)) <= float(exact_value(b.rad())) + 1e-60
        for (t, _, _), ht in zip(r.slave_impacts, h.slave_impacts_t, strict=True):
            assert abs(mpmath.mpf(str(ht)) - _mp(t)) <= float(exact_value(t.rad())) + 1e-60


@pytest.mark.parametrize("method", ["lohner", "interval"])
def test_diagonal_is_the_single_oscillator_exactly(method):
    """On the diagonal the slave is the master in every form (all coupling terms vanish):
    the single oscillator's run of the same method, ball for ball."""
    p = pi.Params.make(eta="0.74")
    r = pi.certify_coupled(p, "0.3", "paper", 30, precision="mp:192", method=method)
    s = pi.certify(p, 30, precision="mp:192", method=method)
    assert r.method == s.method == method
    assert len(r.master_impacts) == len(r.slave_impacts) == len(s.impacts) == 20

    def same(a, b):  # the same ball: midpoint and radius
        return exact_value(a.mid()) == exact_value(b.mid()) and exact_value(a.rad()) == exact_value(
            b.rad()
        )

    for (_, _, x, v, y, w), (_, _, x2, v2) in zip(r.samples, s.samples, strict=True):
        assert same(x, x2) and same(y, x2) and same(v, v2) and same(w, v2)


def test_near_simultaneous_impacts_refused_then_ordered():
    """The slave 1e-90 ahead of the master: their impacts are ~1e-92 apart.  At 256 bits
    (impact balls ~1e-75) the order cannot be proven: an error naming the time, never a guess;
    doubling the bits (512: balls ~1e-149) orders every pair of impacts."""
    p = pi.Params.make(eta="0.712")
    y0 = (Fraction(1, 10**90), "0")
    with pytest.raises(
        CertificationError, match=r"simultaneous master and slave impacts .* at t = 8\.24167"
    ):
        pi.certify_coupled(p, "0.1", "reduced", 5, y0=y0, precision="mp:256", max_bits=256)
    r = pi.certify_coupled(p, "0.1", "reduced", 5, y0=y0, precision="mp:256")
    assert r.bits == 512 and len(r.master_impacts) == len(r.slave_impacts) == 4
    for (tm, _, _), (ts, _, _) in zip(r.master_impacts, r.slave_impacts, strict=True):
        gap = abs(float((ts - tm).mid()))
        # |e| ~ 1e-90 decays like exp(-(zeta + k) t) <= 1; |y'| ~ 1: the impacts 1e-93 .. 1e-90
        # apart
        assert 1e-94 < gap < 1e-89 and not ts.overlaps(tm)


def test_pair_bad_input_one_line_exit_2():
    for argv, word in (
        (["--k", "-1", "--y0", "0.5", "0"], "k"),
        (["--k", "9", "--form", "paper", "--y0", "0.5", "0"], "k"),
        (["--k", "0.1", "--y0", "3", "0"], "y0[0]"),
        (["--y0", "0.5", "0"], "y0"),
        (["--k", "0.1", "--form", "nonsense"], "form"),
        (
            ["--k", "0.1", "--precision", "mp:256", "--target", "1e-40", "--y0", "0.5", "0"],
            "target",
        ),
        (["--k", "0.1", "--precision", "auto", "--target", "1e-2", "--y0", "0.5", "0"], "target"),
    ):
        r = subprocess.run(
            [sys.executable, "-m", "precise_impact", "certify", "--periods", "2", *argv],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and word in r.stderr, (
            argv,
            r.stderr,
        )


def test_pair_cli_json():
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "precise_impact",
            "certify",
            "--k",
            "0.1",
            "--form",
            "reduced",
            "--y0",
            "0.5",
            "0.1",
            "--periods",
            "4",
            "--bits",
            "128",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert (
        d["form"] == "reduced"
        and d["k"] == "0.1"
        and d["y0"] == ["0.5", "0.1"]
        and len(d["samples"]) == 5
    )
    assert set(d["samples"][1]) == {
        "period",
        "t",
        "x",
        "v",
        "y",
        "w",
        "x_rad",
        "v_rad",
        "y_rad",
        "w_rad",
        "x_digits",
        "v_digits",
        "y_digits",
        "w_digits",
    }
    # proven digits: the radius (< 1e-25 on |y| ~ 1) leaves at least 24
    assert d["digits"]["basis"] == "proven" and d["samples"][4]["y_digits"] >= 24
    assert d["slave_impacts"] and set(d["slave_impacts"][0]) == {
        "t",
        "t_rad",
        "before",
        "after",
        "rad",
    }
    assert float(d["samples"][4]["y_rad"]) < 1e-25


@pytest.mark.parametrize("method", ["lohner", "interval"])
def test_pair_radii_below_the_float_range(method):
    """Issue 35 item 2, the pair off the diagonal (k = 0.02, reduced form, 5 periods of
    eta = 0.74) at 2200 and 4096 bits and with the automatic bits for a target of 1e-400:
    every radius to_dict states is the ball's own (within 10 %: rounded up, plus the
    midpoint's decimal rounding; it was ~1e-303, the midpoint's digits stopping at 303),
    below 1e-300; the 4096-bit midpoints lie in the 2200-bit balls (another precision), and
    the master's balls hold the closed-form engine at mp:4096 (mpmath, another engine)."""
    p, y0 = pi.Params.make(eta="0.74"), ("0.5", "0.1")
    runs = {
        how: pi.certify_coupled(p, "0.02", "reduced", 5, y0=y0, method=method, **kw)
        for how, kw in (
            ("mp:2200", {"precision": "mp:2200"}),
            ("mp:4096", {"precision": "mp:4096"}),
            ("1e-400", {"precision": "auto", "target_radius": "1e-400"}),
        )
    }
    assert runs["1e-400"].max_log10_radius() < -400 and runs["1e-400"].bits >= 1329
    for r in runs.values():
        d = r.to_dict()
        json.loads(json.dumps(d, allow_nan=False))
        assert Fraction(d["max_radius"]) < Fraction(1, 10**300) and d["max_log10_radius"] < -300
        for row, (_, _, *balls) in zip(d["samples"][1:], r.samples[1:], strict=True):
            for n, b in zip("xvyw", balls, strict=True):
                rad, stated = exact_value(b.rad()), Fraction(row[n + "_rad"])
                assert 0 < rad <= stated <= rad * Fraction(11, 10) < Fraction(1, 10**300), n
    lo, hi = runs["mp:2200"], runs["mp:4096"]
    for a, b in zip(lo.samples, hi.samples, strict=True):
        for ba, bb in zip(a[2:], b[2:], strict=True):
            assert abs(exact_value(bb.mid()) - exact_value(ba.mid())) <= exact_value(ba.rad())
    h = pi.simulate(p, 5, model="analytical", precision="mp:4096")
    err = Fraction(1, 10**1200)  # its error: 2^-4096 grown < 1e3 over 5 periodic periods
    for k, (_, _, x, v, _, _) in enumerate(lo.samples):
        for ball, ref in ((x, h.x[k]), (v, h.v[k])):
            assert (
                abs(exact_value(ball.mid()) - Fraction(str(ref))) <= exact_value(ball.rad()) + err
            )
