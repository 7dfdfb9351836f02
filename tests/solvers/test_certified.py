"""Certified trajectories and proven periodic orbits, each against an independent reference:
heyoka's multiprecision references (another method, another code), closed forms, the float64
Newton orbits, and constructed near-tangencies whose truth is known exactly."""

import json
import math
import subprocess
import sys
import threading
from fractions import Fraction

import pytest

import precise_impact as pi
from precise_impact.verification.reference import shipped_root

flint = pytest.importorskip("flint", reason="python-flint: pip install python-flint")
from precise_impact.solvers.certified.single import CertificationError, certify  # noqa: E402


def _exact(s):
    return flint.arb(flint.fmpq(Fraction(s).numerator, Fraction(s).denominator))


@pytest.mark.parametrize("case", ["single-0.70", "single-0.712", "single-0.74"])
def test_heyoka_mp_references_lie_within_their_stated_accuracy_of_the_proven_balls(case):
    """The shipped mp:320 heyoka references against certified balls (512 bits, radius <= 1e-70):
    equal impact counts, and every sample's *proven* error |ref - truth| <= |ref - mid| + rad is
    within twice the accuracy the manifest demonstrated by two precisions (the mp:384 run's own
    error is ~2^-384 of that: the factor 2 is room, not slack)."""
    data = json.loads((shipped_root() / case / "samples.json").read_text())
    manifest = json.loads((shipped_root() / case / "manifest.json").read_text())
    p = pi.Params.make(**data["params"])
    r = certify(p, data["periods"], precision="mp:512")
    assert len(r.impacts) == len(data["impacts"]) == manifest["impacts"]
    assert r.max_radius() < 1e-70
    stated = float(manifest["accuracy"]["max_sample_disagreement"])
    worst = 0.0
    old = flint.ctx.prec
    flint.ctx.prec = 1024
    try:
        for s in data["samples"]:
            _, tk, bx, bv = r.samples[s["period"]]
            # the reference's sample time is t_k rounded to mp:320: |dt| <= 2^-319 t_k moves
            # the state by |f| dt < 1e-90, far below the accuracies compared here
            assert abs(float(_exact(s["t"]).mid()) - float(tk.mid())) <= 1e-80 * (
                1 + float(tk.mid())
            )
            for ref, ball in ((s["x"], bx), (s["v"], bv)):
                err = abs(_exact(ref) - ball) + ball.rad()
                worst = max(worst, float(err.upper()))
    finally:
        flint.ctx.prec = old
    assert worst <= 2 * stated + 1e-70, (worst, stated)


def test_a_grazing_impact_missed_by_the_papers_scan_is_found_and_proven():
    """The non-impacting orbit just above the grazing frequency pokes 1.7e-7 past the wall for
    ~1e-3 time units: the paper's scan (steps of 1e-3 T) misses the crossing, the certified
    engine proves it (a crossing isolated, v- > 0) -- as the robust finder, the fast engine and
    heyoka also find."""
    from precise_impact.solvers.closed_form import AnalyticalSolver

    p = pi.Params.make(eta="0.7106874")
    ss = pi.steady_state(p)
    q = p.replace(x0=ss.P, v0=ss.eta * ss.Q)
    paper = AnalyticalSolver(finder="paper", precision="float64").solve(q, 3)
    r = certify(q, 3, precision="mp:256")
    assert paper.n_impacts == 0 and len(r.impacts) == 2
    for other in (
        pi.simulate(q, 3),
        pi.simulate(q, 3, model="fast"),
        pi.simulate(q, 3, model="analytical"),
    ):
        assert other.n_impacts == 2
        for (t, _, _), t2 in zip(r.impacts, other.impacts_t, strict=True):
            assert abs(float(t.mid()) - float(t2)) < 1e-9  # float64 impact times, ~1e-12 apart
    assert all(vb > 0 for _, vb, _ in r.impacts)  # proven transversal


@pytest.mark.parametrize("sign,impacts", [(1, 0), (-1, 2)])
def test_a_near_tangency_beyond_the_precision_is_refused_then_resolved(sign, impacts):
    """x'' = -x from (-1, 0) peaks at exactly 1 at t = pi: with the wall at 1 +- 1e-200 there is
    no impact (+) or one at every return (-).  At 128 bits no proof is possible (an error naming
    the time, never a guess); doubling the bits resolves it either way."""
    p = pi.Params.make(
        a="0", zeta="0", eta="0.5", x0="-1", v0="0", x_w=Fraction(1) + sign * Fraction(1, 10**200)
    )
    with pytest.raises(CertificationError, match=r"t = 3\.14159265358979"):
        certify(p, 1, precision="mp:128", max_bits=128)
    r = certify(p, 1, precision="mp:128", max_bits=4096)
    assert len(r.impacts) == impacts and "no proof at 128 bits" in r.bits_choice and r.bits > 128
    if (
        impacts
    ):  # the wall 1e-200 below the peak: the crossing sqrt(2e-200) = 1.41e-100 before t = pi
        old = flint.ctx.prec
        flint.ctx.prec = 1024
        try:
            gap = flint.arb.pi() - r.impacts[0][0]
            assert abs(gap - flint.arb(2).sqrt() * flint.arb(10) ** -100) < flint.arb(10) ** -250
        finally:
            flint.ctx.prec = old


def test_automatic_bits_reach_the_target_and_say_so():
    r = certify(pi.Params.make(eta="0.712"), 300, method="interval")
    assert r.max_radius() <= 1e-30 and r.bits_choice.startswith("automatic")
    # the naive enclosure loses more than the true sensitivity LLE T / ln 10 = 0.116 digits/period
    assert 0.116 < r.growth_digits_per_period() < 0.5


def test_certified_model_and_threads():
    p = pi.Params.make(eta="0.74")
    tr = pi.simulate(p, 30, model="certified", precision="mp:256")
    ref = pi.simulate(p, 30, precision="mp:256")
    assert tr.n_impacts == ref.n_impacts and float(tr.stats["max_radius"]) < 1e-60
    assert (
        max(abs(a - b) for a, b in zip(tr.x, ref.x, strict=True)) < 1e-60
    )  # heyoka mp:256 vs the proven midpoints
    serial = [
        certify(pi.Params.make(eta=e), 40, precision=f"mp:{b}").to_dict()
        for e, b in (("0.712", 192), ("0.74", 320))
    ] * 2
    out = [None] * 4

    def work(i):
        e, b = (("0.712", 192), ("0.74", 320))[i % 2]
        out[i] = certify(pi.Params.make(eta=e), 40, precision=f"mp:{b}").to_dict()

    ts = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    [t.start() for t in ts]
    [t.join() for t in ts]
    for a, b in zip(out, serial, strict=True):
        assert a["samples"] == b["samples"] and a["bits"] == b["bits"]


def test_proven_period_3_orbit_and_its_stability():
    from precise_impact.analysis.orbits.proof import prove_orbit

    o = prove_orbit(pi.Params.make(eta="0.74"), 3)
    assert o.proven and o.impacts == 2 and o.stable is True
    f = pi.find_orbit(pi.Params.make(eta="0.74"), 3)
    # the float64 Newton orbit lies within its rounding (1e-15) of the proven box
    assert abs(float(o.x[0]) - f.x) < 1e-14 and abs(float(o.v[0]) - f.v) < 1e-14
    for enc, mu in zip(o.multipliers, sorted(f.multipliers, key=lambda m: -abs(m)), strict=True):
        assert abs(float(enc["re"]) - mu.real) < 1e-13
    assert o.lle[0] <= f.lle + 1e-13 and f.lle - 1e-13 <= o.lle[1]


def test_proven_non_impacting_orbit_is_the_closed_form():
    from precise_impact.analysis.orbits.proof import prove_orbit

    o = prove_orbit(pi.Params.make(eta="0.70"), 1, guess=("102/53", "49/265"), impacts=0)
    assert o.proven and o.impacts == 0 and o.stable is True
    old = flint.ctx.prec
    flint.ctx.prec = 512
    try:
        for (mid, rad), q in ((o.x, Fraction(102, 53)), (o.v, Fraction(49, 265))):
            assert abs(_exact(mid) - _exact(q)) < _exact(
                rad
            )  # the closed form lies in the proven box
        # |mu| = exp(-zeta T) exactly: LLE = -zeta
        assert o.lle[0] <= -0.05 <= o.lle[1] and o.lle[1] - o.lle[0] < 1e-15
    finally:
        flint.ctx.prec = old


def test_proven_unstable_orbit():
    from precise_impact.analysis.orbits.proof import prove_orbit

    p = pi.Params.make(eta="0.712")
    unstable = [u for u in pi.one_impact_orbits(p, dps=30) if not u.stable]
    o = prove_orbit(p, 1, guess=(float(unstable[0].x), float(unstable[0].v)), impacts=1)
    assert o.proven and o.stable is False and o.lle[0] > 0


def test_certify_cli_contract():
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "precise_impact",
            "certify",
            "--eta",
            "0.712",
            "--periods",
            "5",
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
    assert d["bits"] == 128 and len(d["samples"]) == 6
    assert set(d["samples"][1]) == {"period", "t", "x", "v", "x_rad", "v_rad"}
    assert set(d["impacts"][0]) == {"t", "t_rad", "v_before", "v_after", "v_rad"}
    assert float(d["samples"][5]["x_rad"]) < 1e-30
    for argv, word in (
        (["--bits", "20"], "bits"),
        (["--target", "1e-2"], "target_radius"),
        (["--periods", "0"], "periods"),
        (["--x0", "3"], "x0"),
    ):
        r = subprocess.run(
            [sys.executable, "-m", "precise_impact", "certify", *argv],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and word in r.stderr, (
            argv,
            r.stderr,
        )


def test_reference_certificates_hold_and_a_false_bound_is_caught(tmp_path):
    """The shipped single cases carry proven error bounds (certificate.json, checksummed); verify
    re-proves them.  A bound tightened below the stored value's true error is refused."""
    import shutil

    from precise_impact.io.atomic import sha256_file
    from precise_impact.verification.certificate import CERTIFICATE, check_certificate
    from precise_impact.verification.reference import verify

    for case in ("single-0.70", "single-0.712", "single-0.74"):
        m = json.loads((shipped_root() / case / "manifest.json").read_text())
        assert (
            CERTIFICATE in m["files"]
            and float(m["proof"]["max_proven_error"])
            <= 2 * float(m["accuracy"]["max_sample_disagreement"]) + 1e-80
        )
    d = tmp_path / "single-0.74"
    shutil.copytree(shipped_root() / "single-0.74", d)
    assert check_certificate("single-0.74", d) == []
    cert = json.loads((d / CERTIFICATE).read_text())
    cert["samples"][150]["x_err"] = "1e-120"  # the stored x there is ~1e-93 from the truth
    (d / CERTIFICATE).write_text(json.dumps(cert))
    m = json.loads((d / "manifest.json").read_text())
    m["files"][CERTIFICATE]["sha256"] = sha256_file(d / CERTIFICATE)
    (d / "manifest.json").write_text(json.dumps(m))
    problems = verify(tmp_path, "single-0.74")
    assert len(problems) == 1 and "period 150" in problems[0] and "proven bound" in problems[0]


def test_fast_engine_scored_against_proven_balls():
    """A regression test against proven truth: the fast engine's period-3 orbit over 100 periods
    stays within 4 eps t max|v| (its stated rounding growth) of the certified balls."""
    p = pi.Params.make(eta="0.74")
    r = certify(p, 100, precision="mp:192")
    tr = pi.simulate(p, 100, model="fast")
    eps = 2.0**-52
    for k in range(1, 101):
        _, tk, bx, bv = r.samples[k]
        bound = 4 * eps * float(tk.mid()) * 2.5 + float(
            bx.rad().mid()
        )  # max |v| ~ 2.4 on this orbit
        assert (
            abs(float(tr.x[k]) - float(bx.mid())) <= bound
            and abs(float(tr.v[k]) - float(bv.mid())) <= bound
        )


def test_users_scores_carry_proven_error_bounds():
    """precise_impact.testing scores a user's solver with a *proven* bound of |y - truth| (the
    certificate's bound of |y_ref - truth| added): it must never be below the true error, whose
    lower bound |y - mid| - rad comes from a fresh certified run (another computation)."""
    from precise_impact.testing import load_reference, score_solver

    def fast(params, periods):
        tr = pi.simulate(pi.Params.make(**params), periods, model="fast")
        return tr.x, tr.v

    ref = load_reference("single-0.712")
    assert ref.proven_x_err is not None and max(ref.proven_x_err) < 1e-50
    s = score_solver(fast, "single-0.712", periods=60, atol=1e-9, rtol=1e-9)
    r = certify(pi.Params.make(**ref.params), 60, precision="mp:256")
    old = flint.ctx.prec
    flint.ctx.prec = 256
    try:
        for k in range(61):
            _, _, bx, bv = r.samples[k]
            for y, ball, bound in (
                (s["solver_x"][k], bx, s["proven_error_x"][k]),
                (s["solver_v"][k], bv, s["proven_error_v"][k]),
            ):
                true_lower = abs(flint.arb(float(y)) - ball).lower()  # <= |y - truth|
                assert float(true_lower) <= bound
                assert (
                    bound
                    <= s["abs_error_x" if ball is bx else "abs_error_v"][k] * (1 + 1e-12) + 1e-50
                )
    finally:
        flint.ctx.prec = old


def test_targets_below_the_float_range_are_met_not_underflowed():
    """A radius below 1e-308 is 0.0 as a float: the target check and the growth use log10 of the
    exact dyadic radius instead (a float comparison would pass 0.0 <= 0.0 for any radius)."""
    r = certify(pi.Params.make(eta="0.712"), 20, target_radius="1e-400")
    assert r.max_log10_radius() <= -400 and r.bits >= 1400  # 400 digits need >= 1329 bits
    # the float view: rounded up, a bound (the smallest subnormal), never 0.0 (was 0.0)
    assert r.max_radius() == math.ulp(0.0) and all(x == math.ulp(0.0) for x in r.radii()[1:])
    assert 0.116 < r.growth_digits_per_period() < 0.5


def test_contains_is_exact():
    """CertifiedTrajectory.contains decides in rationals: the midpoint is in, a point two radii
    away is out, whatever python-flint's (process-wide) precision is at the time."""
    from precise_impact.solvers.certified.single import exact_value

    r = certify(pi.Params.make(eta="0.74"), 5, precision="mp:256")
    _, _, bx, bv = r.samples[5]
    mx, mv, rx = exact_value(bx.mid()), exact_value(bv.mid()), exact_value(bx.rad())
    old = flint.ctx.prec
    flint.ctx.prec = 53  # a careless caller elsewhere: must not matter
    try:
        assert r.contains(5, mx, mv) and r.contains(5, mx + rx, mv)
        assert not r.contains(5, mx + 2 * rx, mv) and not r.contains(5, mx, mv + 1)
    finally:
        flint.ctx.prec = old


def test_a_start_on_the_wall_moving_in_is_post_impact_at_sample_0():
    """Samples are right-continuous in every engine (docs/numerics.rst): from x0 = x_w = 2,
    v0 = 1 there is an impact at t0 and sample 0 is (x_w, -R v0).  Before, the certified run
    kept the pre-impact v0 = 1 at sample 0, so heyoka's mp:256 / mp:320 sample 0 lay
    outside its ball (R = 1 here: v = -1 after the impact)."""
    p = pi.Params.make(x0="2", v0="1")
    r = certify(p, 3, precision="mp:256")
    assert r.contains(0, p.x_w, -p.R * p.v0) and not r.contains(0, p.x0, p.v0)
    assert len(r.impacts) >= 1 and r.impacts[0][0].is_zero()
    # another engine's mp:256 samples (the closed form: heyoka's mp JIT costs ~10 s here)
    h = pi.simulate(p, 3, model="analytical", precision="mp:256")
    assert all(r.contains(k, str(h.x[k]), str(h.v[k])) for k in range(4))


def test_radii_below_the_float_range_are_strings_never_zero():
    """At mp:4096 the radii are ~1e-1230: as floats they were 0.0 in stats / to_dict (a bound
    shown as exactness).  Now decimal strings in scientific notation, rounded up; '0' only for
    an exact point (sample 0 of x0 = v0 = 0)."""
    from precise_impact.solvers.certified.single import exact_value, radius_str

    p = pi.Params.make(eta="0.74")
    tr = pi.simulate(p, 3, model="certified", precision="mp:4096")
    rads = tr.stats["x_rad"][1:] + tr.stats["v_rad"][1:] + [tr.stats["max_radius"]]
    assert tr.stats["x_rad"][0] == tr.stats["v_rad"][0] == "0"
    assert all("e-12" in s and 0 < Fraction(s) and float(s) == 0.0 for s in rads), rads
    r = certify(p, 3, precision="mp:4096")
    d = r.to_dict()
    assert d["max_radius"] == tr.stats["max_radius"] and Fraction(d["max_radius"]) > 0
    # rounded up: never below the exact radius of the ball
    for _, _, x, v in r.samples:
        for b in (x, v):
            assert Fraction(radius_str(b.rad())) >= exact_value(b.rad())
    assert radius_str(flint.arb(0).rad()) == "0"


def test_automatic_bits_escalate_when_the_pilot_fails():
    """eta = 1, R = 0.8: the 128-bit pilot cannot prove a departure at t ~ 226 (period 36).
    Before, certify gave up (CLI exit 3) although 256 bits certify it; now the pilot doubles.
    (The interval scheme's boxes; the Lohner enclosure proves it at 128 bits.)"""
    r = certify(pi.Params.make(eta="1", R="0.8"), 40, method="interval")
    assert r.bits >= 256 and "no proof at 128 bits" in r.bits_choice
    assert r.max_log10_radius() <= -30
    r = certify(pi.Params.make(eta="1", R="0.8"), 40)
    assert r.method == "lohner" and "no proof" not in r.bits_choice
    assert r.max_log10_radius() <= -30


def test_a_bisection_deeper_than_pythons_recursion_limit_is_refused_not_crashed():
    """A graze g(t) = -(t - c)^2 bisected to max_depth = bits + 40 = 1064 levels at 1024 bits:
    the recursive bisection raised RecursionError (a traceback from ``certify --bits 64
    --periods 2000`` after the bits doubled to 1024); the iterative one raises the
    CertificationError that names the graze."""
    from precise_impact.solvers.certified.single import Isolator, to_ball, working_bits

    with working_bits(1024):
        c = to_ball(Fraction(1, 3))

        def gap(t):
            return -(t - c) * (t - c), -2 * (t - c)

        with pytest.raises(CertificationError, match="cannot be separated from a graze"):
            Isolator(1024).first_crossing(gap, flint.arb(2), flint.arb(0), flint.arb(1))


def test_contains_refuses_a_sample_index_out_of_range():
    r = certify(pi.Params.make(eta="0.74"), 5, precision="mp:128")
    for k in (99, 6, -1):
        with pytest.raises(pi.ParameterError, match=r"^k = .*0 <= k <= 5"):
            r.contains(k, 0, 0)
    assert r.contains(5, *(exact_value_mid(b) for b in r.samples[5][2:]))


def exact_value_mid(b):
    from precise_impact.solvers.certified.single import exact_value

    return exact_value(b.mid())


def _cli(argv, capsys):
    from precise_impact.cli.main import main

    try:
        rc = main(argv)
    except SystemExit as e:  # argparse
        rc = e.code
    out, err = capsys.readouterr()
    return rc, out, err


def test_certify_cli_refuses_conflicting_or_ignored_flags(capsys):
    """--target with fixed bits, and --form without --k, were silently ignored."""
    for argv, word in (
        (["--bits", "128", "--target", "1e-100"], "target"),
        (["--precision", "mp:128", "--target", "1e-100"], "target"),
        (["--form", "paper"], "form"),
    ):
        rc, out, err = _cli(["certify", "--periods", "2", *argv], capsys)
        lines = [s for s in err.splitlines() if "deprecated" not in s]
        assert rc == 2 and len(lines) == 1 and word in lines[0] and out == "", (argv, err)


def test_certify_cli_json_is_strict_for_exact_points(capsys):
    """a = 0 from rest: every sample is the exact point 0, whose log10 radius is -inf; the JSON
    had a bare -Infinity token."""

    def no_constants(name):
        raise AssertionError(f"non-JSON token {name}")

    rc, out, _ = _cli(["certify", "--a", "0", "--periods", "2", "--json"], capsys)
    assert rc == 0
    d = json.loads(out, parse_constant=no_constants)
    assert d["max_radius"] == "0" and d["max_log10_radius"] is None


# ---- issue 35 item 2: radii below the float range, stated and checked exactly ----------------
@pytest.fixture(scope="session")
def closed_form_refs():
    """The closed-form engine's samples of eta = 0.74 at mp:4096 and mp:8192 (another engine in
    mpmath, not arb): x, v as exact rationals per sample.  Their own error: 5 periods of a
    periodic regime lose < 3 digits, so <= 1e-1200 (mp:4096) and <= 1e-2400 (mp:8192)."""
    p = pi.Params.make(eta="0.74")
    out = {}
    for bits, err in ((4096, Fraction(1, 10**1200)), (8192, Fraction(1, 10**2400))):
        h = pi.simulate(p, 5, model="analytical", precision=f"mp:{bits}")
        out[bits] = ([(Fraction(str(h.x[k])), Fraction(str(h.v[k]))) for k in range(6)], err)
    return p, out


def _check_stated_radii(r, refs, err):
    """Every sample of ``r`` (k >= 1): the radius ``to_dict`` states is the ball's own (rounded
    up, plus the midpoint's decimal rounding: within 10 %), below 1e-300, and the stated
    ``mid +- rad`` holds the reference (widened by the reference's error)."""
    from precise_impact.solvers.certified.single import exact_value

    d = r.to_dict()
    for k in range(1, 6):
        row, (_, _, bx, bv) = d["samples"][k], r.samples[k]
        for name, ball, ref in (("x", bx, refs[k][0]), ("v", bv, refs[k][1])):
            rad, stated = exact_value(ball.rad()), Fraction(row[name + "_rad"])
            assert 0 < rad <= stated <= rad * Fraction(11, 10), (k, name, row[name + "_rad"])
            assert stated < Fraction(1, 10**300) and ball.rad() < flint.arb(10) ** -300
            assert abs(Fraction(row[name]) - ref) <= stated + err
    assert Fraction(d["max_radius"]) < Fraction(1, 10**300) and d["max_log10_radius"] < -300
    json.loads(json.dumps(d, allow_nan=False))


@pytest.mark.parametrize("method", ["lohner", "interval"])
@pytest.mark.parametrize("how", ["mp:2200", "mp:4096", "1e-400"])
def test_certify_states_radii_below_the_float_range(closed_form_refs, method, how):
    """The sample radii of to_dict were those of ball_str, whose midpoint digits stopped at 303
    (``float(scale / rad)`` was capped at 1e300): every radius below 1e-300 was stated as
    ~1e-303 (2.56e-303 for a ball of 1e-421 at 1408 bits).  Now the ball's own radius."""
    p, refs = closed_form_refs
    kw = {"target_radius": how} if how.startswith("1e") else {"precision": how}
    r = certify(p, 5, method=method, **kw)
    assert r.bits == {"mp:2200": 2200, "mp:4096": 4096, "1e-400": 1408}[how]
    if how == "1e-400":
        assert r.max_log10_radius() < -400
    _check_stated_radii(r, *refs[8192 if r.bits == 4096 else 4096])


def test_certify_cli_target_1e_400(capsys):
    """``certify --target 1e-400``: the printed '+-' of the last sample was 2.56e-303 (the
    midpoint's 303 digits) for a ball of 1e-421; --json strict; a target of 0, a negative or a
    non-finite one exits 2."""
    rc, out, _ = _cli(["certify", "--eta", "0.74", "--periods", "3", "--target", "1e-400"], capsys)
    assert rc == 0
    pm = [Fraction(line.split(" +- ")[1]) for line in out.splitlines() if " +- " in line]
    assert len(pm) == 2 and all(0 < q < Fraction(1, 10**400) for q in pm), out[-300:]
    largest = Fraction(out.split("largest radius ")[1].split(";")[0])
    assert 0 < largest < Fraction(1, 10**400)
    argv = ["certify", "--eta", "0.74", "--periods", "3", "--target", "1e-400", "--json"]
    rc, out, _ = _cli(argv, capsys)

    def no_constants(name):
        raise AssertionError(f"non-JSON token {name}")

    d = json.loads(out, parse_constant=no_constants)
    assert rc == 0 and Fraction(d["samples"][3]["x_rad"]) < Fraction(1, 10**400)
    for bad in ("0", "-1e-400", "inf", "nan", "1e-3001"):
        rc, out, err = _cli(["certify", "--periods", "3", "--target", bad], capsys)
        assert rc == 2 and err.count("\n") == 1 and "target_radius" in err and out == "", bad


def test_dataframe_radii_below_the_float_range_are_bounds_not_zero():
    """to_dataframe's radius columns (float64) were ``float(rad) * (1 + 2^-50)``: 0.0 for a
    ball of 1e-659, stating an exact point.  Now rounded up to a float64 (the smallest
    subnormal): 0.0 only for sample 0, the exact start."""
    pytest.importorskip("pandas")
    r = certify(pi.Params.make(eta="0.74"), 3, precision="mp:2200")
    df = r.to_dataframe()
    for col in ("rad_x [1]", "rad_v [1]"):
        assert df[col].iloc[0] == 0.0 and all(df[col].iloc[1:] == math.ulp(0.0)), df[col]
    imps = r.to_dataframe("impacts")
    assert all(imps["rad_t [1]"] > 0) and all(imps["rad_v_before [1]"] > 0)


def test_log10_str_prints_any_magnitude():
    """A ratio or radius known by its log10 printed in scientific notation at any magnitude
    (the CLI's Krawczyk contraction below 1e-308), its mantissa rounded to 3 digits."""
    from precise_impact.solvers.certified.single import log10_str

    assert log10_str(-330.0) == "1.00e-330" and log10_str(-math.inf) == "0"
    assert log10_str(math.log10(2.5) - 400) == "2.50e-400"
    assert log10_str(math.log10(9.9996) - 5) == "1.00e-04"  # 9.9996 rounds up to 10
    assert log10_str(math.log10(6.0) + 93) == "6.00e+93" == f"{6e93:.2e}"


@pytest.mark.parametrize("max_bits", [100, "100"])
def test_precision_above_max_bits_names_max_bits(max_bits):
    """``precision='mp:128'`` with ``max_bits=100``: the refusal names ``max_bits`` (the limit
    the two disagree on) and the precision's bits, in one line, before any work (it named
    only ``precision``, with a range ending at 100)."""
    with pytest.raises(pi.ParameterError) as e:
        pi.certify(pi.Params.make(), 5, max_bits=max_bits, precision="mp:128")
    assert e.value.name == "max_bits" and "128" in str(e.value) and "\n" not in str(e.value)
