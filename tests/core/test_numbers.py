"""One number parser, bounded before any arithmetic; every public entry validates; precisions
reported as used.

Each hostile value of the reliability review must end at once with exit status 2 and
one line naming the parameter and the allowed range (no traceback, no hang).
"""

from __future__ import annotations

import subprocess
import sys
import time
from fractions import Fraction

import numpy as np
import pytest

import precise_impact as pi
from precise_impact.core.params import MAX_DIGITS, exact

HOSTILE = [
    "1e308",
    "1e309",
    "1e400",
    "1e-320",
    "-1e308",
    "1e999999999",
    "-1e999999999",
    "1e-999999999",
    "9" * 5000,
    "1" * 401,
    "nan",
    "inf",
    "-inf",
    "1/0",
    "0x10",
    "",
    "1e",
    "--",
    "1e-101",
    "1e101",
]


@pytest.mark.parametrize("value", HOSTILE, ids=lambda v: v[:12] or "empty")
def test_hostile_numbers_are_refused_at_once(value):
    t = time.perf_counter()
    with pytest.raises(pi.ParameterError) as e:
        exact("eta", value)
    assert time.perf_counter() - t < 0.1  # sizes and exponents are checked before expansion
    assert e.value.name == "eta" and len(str(e.value)) < 200


@pytest.mark.parametrize(
    "flag,value",
    [
        ("--eta", "1e999999999"),
        ("--R", "1e999999999"),
        ("--zeta", "1e-999999999"),
        ("--tol", "1e-999999999"),
        ("--tol", "1e-300"),
        ("--precision", "mp:100000"),
        ("--x_w", "1e309"),
        ("--a", "9" * 5000),
        ("--t0", "-1e308"),
    ],
)
def test_cli_refuses_hostile_values_with_one_line(flag, value):
    t = time.perf_counter()
    r = subprocess.run(
        [sys.executable, "-m", "precise_impact", "simulate", flag, value, "--periods", "2"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    name = flag.lstrip("-")
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert f"{name} = " in lines[0] and "not allowed" in lines[0]
    assert time.perf_counter() - t < 30


def test_the_range_is_inclusive_and_exact():
    assert exact("a", "1e100") == 10**100 and exact("a", "-1e-100") == Fraction(-1, 10**100)
    assert exact("a", "0") == 0 and exact("a", "102/53") == Fraction(102, 53)
    longest = "0." + "1" * (MAX_DIGITS - 2)  # exactly MAX_DIGITS characters: accepted, exact
    assert exact("a", longest) == Fraction(int("1" * (MAX_DIGITS - 2)), 10 ** (MAX_DIGITS - 2))


def test_numpy_scalars_and_mappings_are_accepted():
    assert pi.Params.make(eta=np.float64(0.712)).eta == Fraction(
        89, 125
    )  # the shortest round-trip decimal
    assert pi.Params.make(x_w=np.int32(3)).x_w == 3
    assert pi.simulate({"eta": "0.74"}, 2).params.eta == Fraction(37, 50)
    with pytest.raises(pi.ParameterError) as e:
        pi.simulate(["eta"], 2)
    assert e.value.name == "params"


def test_a_params_is_validated_however_it_was_built():
    with pytest.raises(pi.ParameterError) as e:
        pi.Params(zeta=0, a=1, eta=-1, x_w=2, R=1, x0=0, v0=0, t0=0)
    assert e.value.name == "eta"
    import dataclasses

    with pytest.raises(pi.ParameterError) as e:
        dataclasses.replace(pi.Params.make(), R=2)
    assert e.value.name == "R"


def test_tolerance_below_epsilon_is_refused_per_precision():
    with pytest.raises(pi.ParameterError) as e:
        pi.HeyokaSolver("float64", tol="1e-17")  # float64's eps is 2.2e-16
    assert e.value.name == "tol" and "2^-52" in str(e.value)
    pi.HeyokaSolver("mp:128", tol="1e-35")  # 128 bits: eps = 2^-127 = 5.9e-39, so 1e-35 is legal


def test_multiprecision_ceiling_is_stated():
    with pytest.raises(pi.ParameterError) as e:
        pi.Precision.parse("mp:8193")
    assert "64 <= BITS <= 8192" in str(e.value)
    assert pi.Precision.parse("mp:8192").bits == 8192


@pytest.mark.parametrize("bits", [64, 136, 320])
def test_the_precision_reported_is_the_precision_used(bits):
    """0.1.0 reported mp:323 for mp:320 and mp:133 for mp:136 (via decimal digits)."""
    tr = pi.simulate(pi.Params.make(eta="0.74"), 2, model="analytical", precision=f"mp:{bits}")
    assert tr.precision.name == f"mp:{bits}"
    # and it really computed at that width: the samples carry `bits` bits, not more
    assert all(tr.precision.to_mpf(x)._mpf_[3] <= bits for x in tr.x)


@pytest.mark.parametrize(
    "name,edge,beyond",
    [
        ("eta", "1000", "1000.001"),
        ("eta", "0.001", "0.000999"),
        ("zeta", "1000", "1001"),
        ("a", "1e6", "1000001"),
        ("t0", "1e9", "-1000000001"),
    ],
)
def test_the_parameter_box_edges_run_and_beyond_is_refused(name, edge, beyond):
    """Legal values run (float64 overflowed at eta = 1e20 before the box existed: heyoka
    stopped with a non-finite state); the first value outside is refused by name."""
    tr = pi.simulate(pi.Params.make(**{name: edge}), 1)
    assert np.all(np.isfinite(np.asarray(tr.x, dtype=float)))
    with pytest.raises(pi.ParameterError) as e:
        pi.Params.make(**{name: beyond})
    assert e.value.name == name
