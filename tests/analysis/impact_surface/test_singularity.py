"""The singularity set: every point's next flight touches the wall (checked independently in
mpmath), the curves are continuous, and its images are the map's one-sided limits."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

import precise_impact as pi
from precise_impact.analysis.impact_surface.impact_map import impact_map
from precise_impact.analysis.impact_surface.singularity import singularity_set


@pytest.fixture(scope="module")
def chaotic_set():
    return singularity_set(pi.Params.make(eta="0.712"), step=0.01)


def test_every_point_touches_the_wall(chaotic_set):
    # independent check in mpmath (30 digits): the flight from (x_w, -R v) at t = 2 pi phase / eta
    # written out here, its maximum located by solving x' = 0 from s, then |x_max - x_w| <= 1e-12
    # (the float64 continuation solves the grazing condition to ~1e-15)
    ctx = mpmath.MPContext()
    ctx.dps = 30
    zeta, eta, x_w = ctx.mpf("0.05"), ctx.mpf("0.712"), ctx.mpf(2)
    d = (1 - eta**2) ** 2 + (2 * zeta * eta) ** 2
    P, Q = (1 - eta**2) / d, 2 * zeta * eta / d
    wd = ctx.sqrt(1 - zeta**2)
    n = 0
    for b in chaotic_set.branches:
        assert len(b["phase"]) > 20
        for phase, v, s in zip(b["phase"], b["v"], b["s"], strict=True):
            t0 = 2 * ctx.pi * ctx.mpf(phase) / eta
            xp0 = P * ctx.cos(eta * t0) + Q * ctx.sin(eta * t0)
            vp0 = eta * (Q * ctx.cos(eta * t0) - P * ctx.sin(eta * t0))
            y0, u0 = x_w - xp0, -ctx.mpf(v) - vp0  # R = 1
            A, B = y0, (u0 + zeta * y0) / wd

            A1, B1 = B * wd - zeta * A, -A * wd - zeta * B  # of y' = e^(-zeta tau) (...)

            def xv(t, t0=t0, A=A, B=B, A1=A1, B1=B1):
                tau = t - t0
                c, sn = ctx.cos(eta * t), ctx.sin(eta * t)
                e, cw, sw = ctx.exp(-zeta * tau), ctx.cos(wd * tau), ctx.sin(wd * tau)
                return (
                    P * c + Q * sn + e * (A * cw + B * sw),
                    eta * (Q * c - P * sn) + e * (A1 * cw + B1 * sw),
                )

            def acc(t, xv=xv):  # the equation of motion, a = 1
                x, xd = xv(t)
                return ctx.cos(eta * t) - 2 * zeta * xd - x

            # Newton on x'(t) = 0 from the continuation's s (x'' from the equation of motion)
            tm = t0 + ctx.mpf(s)
            for _ in range(20):
                dt = xv(tm)[1] / acc(tm)
                tm -= dt
                if abs(dt) < ctx.mpf(10) ** -25:
                    break
            assert abs(tm - t0 - ctx.mpf(s)) < 1e-6
            assert acc(tm) < 0  # a maximum
            assert abs(xv(tm)[0] - x_w) <= 1e-12
            n += 1
    assert n > 500


def test_curves_are_continuous(chaotic_set):
    # neighbouring points one pseudo-arclength step apart: the corrector keeps the projection
    # on the tangent equal to the step, so the chord exceeds it only by O(step^2 curvature)
    assert 0 < chaotic_set.max_step <= 0.01 * 1.01
    for b in chaotic_set.branches:
        ph, v = np.array(b["phase"]), np.array(b["v"])
        dph = (np.diff(ph) + 0.5) % 1 - 0.5
        assert np.hypot(dph, np.diff(v)).max() <= 0.01 * 1.01


def test_images_are_the_one_sided_limits(chaotic_set):
    # an impact just on one side of the set grazes-and-misses, on the other it hits near v = 0:
    # the map jumps between the set's two images
    b = chaotic_set.branches[0]
    k = len(b["phase"]) // 2
    ph, v, s = b["phase"][k], b["v"][k], b["s"][k]
    params = pi.Params.make(eta="0.712")
    sides = []
    for dv in (-1e-7, 1e-7):
        e = impact_map(params, ph, v + dv, 1, engine="closed-form", bits=100)[0]
        sides.append((float(e.phase), float(e.v)))
    slow = min(sides, key=lambda p: p[1])
    fast = max(sides, key=lambda p: p[1])
    # near the graze: v ~ sqrt(2 |x''| |dx|) ~ 1e-3.5: small, at the grazing phase
    assert slow[1] < 1e-2
    assert abs(slow[0] - b["graze_phase"][k]) < 1e-3
    assert b["after_phase"][k] is not None
    assert abs(fast[0] - b["after_phase"][k]) < 1e-4 and abs(fast[1] - b["after_v"][k]) < 1e-4
    assert s > 0


def test_bad_input():
    with pytest.raises(pi.ParameterError, match="step"):
        singularity_set(pi.Params.make(), step=1.0)


def test_virtual_points_have_an_earlier_impact():
    # Budd-Dux style (zeta = 0, R = 0.5, omega = 2.8, sigma = 0): the dotted parts of the set are
    # tangencies that an earlier impact on the same flight pre-empts; the map (heyoka, whose
    # contact rule also covers the chattering this model does) finds that impact (or the first
    # impact of a chattering sequence) before the tangency, at every sampled virtual point
    params = pi.Params.make(zeta=0, R="0.5", eta="2.8", x_w="0", x0="0")
    r = singularity_set(params, v_max=2.0, step=0.02)
    virtual = [
        (ph, v, s)
        for b in r.branches
        for ph, v, s, ok in zip(b["phase"], b["v"], b["s"], b["physical"], strict=True)
        if not ok
    ]
    assert len(virtual) > 10
    for ph, v, s in virtual[:: max(1, len(virtual) // 8)]:
        e = impact_map(params, ph, v, 1, engine="heyoka")[0]
        t0 = 2 * np.pi * ph / 2.8
        assert e.kind in ("impact", "chatter") and float(e.t) - t0 < s - 1e-6
