"""Periodic orbits, second part: the area-preserving case (zeta = 0, R = 1: elliptic orbits, no
false Neimark-Sacker points), the closed-form 1:n orbits and the seeding of Newton from them,
quadratic convergence of the multiprecision Newton, and the ``orbit --json`` state types.

Independent references: the closed forms of ``one_impact_orbits`` (mpmath), heyoka mp:192
simulations, and the identity ``det M = R^(2n) exp(-2 zeta p T)``.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from fractions import Fraction

import mpmath
import numpy as np
import pytest

import precise_impact as pi
from precise_impact import Params, simulate
from precise_impact.analysis.orbits import find_orbit, one_impact_orbits

EPS = 2.0**-52


def test_area_preserving_orbits_are_elliptic_without_neimark_sacker():
    """zeta = 0, R = 1: det M = 1 identically, so det M - 1 is rounding noise (before the fix this
    continuation reported 17 Neimark-Sacker points and 'stable' flipped at 12 of 44 points).  The
    1:1 orbit from eta = 1.3 to 1.6 (t0 = 1) has |tr M| < 2 along the whole branch, i.e. a complex
    pair on the unit circle: every point must be 'elliptic', never 'stable', with LLE exactly 0,
    and no Neimark-Sacker point may be reported."""
    p = Params.make(zeta="0", R="1", eta="1.3", t0="1")
    res = pi.continue_orbit(p, "eta", "1.3", "1.6", 1)
    assert not any(b.type == "neimark-sacker" for b in res.bifurcations), [
        (b.type, b.value) for b in res.bifurcations
    ]
    b = res.branches[0]
    assert b.values.max() == 1.6 and b.impacts == 1
    mu = b.multipliers[..., 0] + 1j * b.multipliers[..., 1]
    tr = (mu[:, 0] + mu[:, 1]).real
    # the classification rests on |tr| < 2; rounding moves tr by ~1e-15, the margin is measured
    assert np.abs(tr).max() < 2 - 1e-6
    assert list(b.stability) == ["elliptic"] * len(b.values)
    assert not b.stable.any() and np.all(b.lle == 0.0)
    # |mu| = 1 to rounding (eigenvalues of a 2x2 product of ~10 closed forms: ~100 eps)
    assert np.abs(np.abs(mu) - 1).max() < 100 * EPS
    d = res.to_dict()["branches"][0]
    assert set(d["stability"]) == {"elliptic"} and d["stable"] == [False] * len(b.values)
    # the same classification from Newton and from the closed form
    o = find_orbit(p, 1, guess=(b.x[0, 0], b.v[0, 0]))
    assert (
        o.stability == "elliptic"
        and not o.stable
        and o.lle == 0.0
        and o.to_dict()["stability"] == "elliptic"
    )
    cf = one_impact_orbits(p, dps=30)
    assert cf and all(c.stability in ("elliptic", "unstable") for c in cf)
    assert any(c.stability == "elliptic" and abs(float(c.x) - o.x) < 1e-12 for c in cf)
    # with damping nothing is elliptic: the same branch is asymptotically stable
    damped = find_orbit(p.replace(zeta=Fraction(1, 20)), 1, guess=(o.x, o.v))
    assert damped.stability == "stable" and damped.stable


def test_one_to_two_orbit_closed_form_equals_newton_and_heyoka():
    """R = 0.8, eta = 0.9: one impact per two forcing periods (derived in one_impact.py).  Newton
    (the fast engine's map with the wall) from the closed form, and from a simulation-free seed,
    lands on it to 1e-12: the map's rounding over 2 periods (~100 roundings of O(1) values) times
    |(M - I)^-1| <= 1 / (1 - |mu|) ~ 1.7.  Multipliers: a well-separated complex pair,
    perturbed like M itself, ~1e-14.  Heyoka mp:192 from the closed-form point (60 digits)
    returns to it after 2 periods with one impact, to its tolerance ~1e-57 (1e-40 leaves room)."""
    p = Params.make(R="0.8", eta="0.9")
    (cf,) = one_impact_orbits(p, dps=60, period=2)
    assert (cf.period, cf.impacts, cf.method) == (2, 1, "closed form") and cf.stable
    nw = find_orbit(p, 2, guess_from="closed-form")
    assert nw.impacts == 1 and nw.period == 2 and nw.stability == "stable"
    assert abs(nw.x - float(cf.x)) <= 1e-12 and abs(nw.v - float(cf.v)) <= 1e-12
    mu_cf = sorted((complex(m) for m in cf.multipliers), key=lambda m: (m.imag, m.real))
    mu_nw = sorted(nw.multipliers, key=lambda m: (m.imag, m.real))
    assert all(abs(a - b) <= 1e-12 for a, b in zip(mu_cf, mu_nw, strict=True))
    # det M = R^2 exp(-2 zeta 2 T): the closed form to its 60 digits
    with mpmath.workdps(60):
        T = 2 * mpmath.pi / mpmath.mpf("0.9")
        det = cf.multipliers[0] * cf.multipliers[1]
        assert (
            abs(det - mpmath.mpf("0.64") * mpmath.exp(-2 * mpmath.mpf("0.05") * 2 * T))
            < mpmath.mpf(10) ** -55
        )
    # auto seeding (impacts=1) finds the same orbit; an explicit guess elsewhere also converges to
    # it
    auto = find_orbit(p, 2, impacts=1, guess_from="auto")
    assert abs(auto.x - nw.x) <= 1e-12
    q = p.replace(x0=mpmath.nstr(cf.x, 60), v0=mpmath.nstr(cf.v, 60))
    tr = simulate(q, 2, precision="mp:192")
    assert tr.n_impacts == 1
    with mpmath.workdps(60):
        assert abs(mpmath.mpf(str(tr.x[-1])) - cf.x) <= mpmath.mpf(10) ** -40
        assert abs(mpmath.mpf(str(tr.v[-1])) - cf.v) <= mpmath.mpf(10) ** -40
    # the 1:1 closed form is unchanged by the generalisation (period=1 is the default)
    (one,) = one_impact_orbits(p.replace(eta=Params.make(eta="1").eta), dps=30)
    (one1,) = one_impact_orbits(p.replace(eta=Params.make(eta="1").eta), dps=30, period=1)
    assert one.x == one1.x and one.period == 1


def test_multiprecision_newton_converges_quadratically():
    """mp:512 refinement of the 1:2 orbit: each step h_{k+1} <= C h_k^2, with C = |(M - I)^-1|
    |P''| / 2 = O(1) here (1e3 leaves three digits), for the steps in the quadratic regime
    (h_k <= 1e-20, h_{k+1} above the 2^-504 floor); the number of multiprecision steps is at most
    log2(512 / 50) + 3 = 6 (digits double per step from float64, then one step to see the floor);
    the result equals the closed form to 2^-500."""
    p = Params.make(R="0.8", eta="0.9")
    o = find_orbit(p, 2, guess_from="closed-form", precision="mp:512")
    mp_steps = o.steps[1:]  # the first is float64 Newton's
    assert 3 <= len(mp_steps) <= math.ceil(math.log2(512 / 50)) + 3, o.steps
    floor = 2.0**-504
    pairs = [
        (a, b) for a, b in zip(mp_steps[:-1], mp_steps[1:], strict=True) if a <= 1e-20 and b > floor
    ]
    assert len(pairs) >= 2, mp_steps
    for a, b in pairs:
        assert b <= 1e3 * a * a, (a, b)
    (cf,) = one_impact_orbits(p, dps=170, period=2)
    assert abs(o.x - cf.x) < mpmath.mpf(2) ** -500 and abs(o.v - cf.v) < mpmath.mpf(2) ** -500


def test_orbit_cli_seed_and_json_state_types(capsys):
    """``--impacts 1`` seeds from the closed form; state.x, state.v are JSON numbers in float64
    (exact round trip) and decimal strings at mp:BITS (documented in --help)."""
    base = [
        sys.executable,
        "-m",
        "precise_impact",
        "orbit",
        "--R",
        "0.8",
        "--eta",
        "0.9",
        "--period",
        "2",
    ]
    r = subprocess.run(
        base + ["--impacts", "1", "--json"], capture_output=True, text=True, timeout=120
    )
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert isinstance(d["state"]["x"], float) and isinstance(d["state"]["v"], float)
    assert d["impacts"] == 1 and d["stability"] == "stable"
    (cf,) = one_impact_orbits(Params.make(R="0.8", eta="0.9"), dps=30, period=2)
    assert abs(d["state"]["x"] - float(cf.x)) <= 1e-12
    r = subprocess.run(
        base + ["--guess-from", "closed-form", "--precision", "mp:128", "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    m = json.loads(r.stdout)
    assert isinstance(m["state"]["x"], str) and isinstance(m["state"]["v"], str)
    (cf,) = one_impact_orbits(Params.make(R="0.8", eta="0.9"), dps=60, period=2)
    with mpmath.workdps(60):
        assert abs(mpmath.mpf(m["state"]["x"]) - cf.x) < mpmath.mpf(2) ** -120
    # the help text in this process: its words are checked, not the process (one start-up of
    # ~1.5 s less)
    from precise_impact.cli.main import main

    with pytest.raises(SystemExit) as e:
        main(["orbit", "--help"])
    assert e.value.code == 0
    h = capsys.readouterr()
    assert "decimal" in h.out and "closed-form" in h.out
    r = subprocess.run(
        base[:-1] + ["3", "--seed", "closed-form"], capture_output=True, text=True, timeout=60
    )
    assert r.returncode != 0 and "closed-form" in r.stderr


def test_prove_orbit_refuses_a_box_below_the_working_precision():
    """Found by the API fuzzer: radius = 1e-400 at 128 bits ended in a float division by zero;
    a box narrower than 2^32 ulps of its centre is refused before work, naming radius."""
    from precise_impact import prove_orbit
    from precise_impact.errors import ParameterError

    with pytest.raises(ParameterError) as e:
        prove_orbit(eta="0.74", radius="1e-400", bits=128)
    assert e.value.name == "radius" and "2^-96" in str(e.value)


# ---- issue 35 item 2: proofs at high precision (radii below the float range) -----------------
def _q(m) -> Fraction:
    """An mpmath number as the exact rational it is (from ``_mpf_``: mpmath 1.4's ``man_exp``
    drops the sign)."""
    sign, man, exp, _ = m._mpf_
    return (-1) ** sign * Fraction(int(man)) * Fraction(2) ** int(exp)


def _in_box(ball: tuple, q: Fraction) -> bool:
    """``q`` in the decimal box ``(mid, rad)``, decided exactly."""
    return abs(Fraction(ball[0]) - q) <= Fraction(ball[1])


@pytest.fixture(scope="session")
def unstable_1_1():
    """The unstable 1:1 orbit of eta = 0.712 in closed form at 1500 digits (~5000 bits: its
    error 1e-1500 is far below the 4096-bit box, 3e-617)."""
    p = Params.make(eta="0.712")
    (u,) = [o for o in one_impact_orbits(p, dps=1500, grid=200) if not o.stable]
    return p, u


@pytest.mark.parametrize("bits", [2200, 4096])
def test_prove_orbit_below_the_float_range_holds_the_closed_form(unstable_1_1, bits):
    """``prove_orbit(..., bits=2200)`` raised ZeroDivisionError (the Krawczyk contraction
    divided by ``float(r)``, 0.0 below 1e-308).  The default box ``2^(-bits/2)`` (7e-332,
    3e-617) is proven, its stated radius is below 1e-300 and holds the closed form; the
    multipliers' enclosures hold the closed-form ones."""
    p, u = unstable_1_1
    o = pi.prove_orbit(p, 1, guess=(float(u.x), float(u.v)), impacts=1, bits=bits)
    assert o.proven and o.stable is False and o.impacts == 1
    r = Fraction(1, 2 ** (bits // 2))
    for ball, ref in ((o.x, u.x), (o.v, u.v)):
        # the stated radius: the box's r, plus the decimal rounding of the midpoint (3 digits)
        assert r <= Fraction(ball[1]) <= r * (1 + Fraction(1, 100))
        assert Fraction(ball[1]) < Fraction(1, 10**300) and _in_box(ball, _q(ref))
    assert all(Fraction(enc["rad"]) < Fraction(1, 10**300) for enc in o.multipliers)
    for mu in u.multipliers:  # real here (-29.4, -0.014); each in one enclosure
        assert any(_in_box((enc["re"], enc["rad"]), _q(mpmath.re(mu))) for enc in o.multipliers)
    # the contraction ~ r: its float view a bound (the smallest subnormal), its log10 exact
    assert o.contraction == math.ulp(0.0) and o.log10_contraction < -300
    json.loads(json.dumps(o.to_dict(), allow_nan=False))


def test_the_issue_35_orbit_at_2200_bits_and_a_box_of_1e_400():
    """The case of the issue, eta = 0.74, p = 3 at 2200 bits, with the default box (7e-332)
    and one of 1e-400; the reference: mpmath's Newton at 2048 bits (616 digits, another
    arithmetic and another zero finder), inside both boxes."""
    p = Params.make(eta="0.74")
    ref = find_orbit(p, 3, precision="mp:2048")
    for radius, r in ((None, Fraction(1, 2**1100)), ("1e-400", Fraction(1, 10**400))):
        o = pi.prove_orbit(p, 3, bits=2200, radius=radius)
        assert o.proven and o.impacts == 2 and o.stable is True
        for ball, q in ((o.x, ref.x), (o.v, ref.v)):
            assert r <= Fraction(ball[1]) <= r * (1 + Fraction(1, 100)) and _in_box(ball, _q(q))
        assert 0 < o.contraction < 1 and o.log10_contraction < -250
