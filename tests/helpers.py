"""Shared cases of the test suite: the paper's systems and the exact checks they admit.

The paper (Denysenko, Balcerzak, Dabrowski): zeta = 0.05, a = 1, x_w = 2, R = 1; eta = 0.70
(periodic after a chaotic transient), 0.712 (chaotic, LLE ~0.0302), 0.74 (period 3).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

import precise_impact as pi

#: The paper's forcing frequencies.
ETA_TRANSIENT, ETA_CHAOTIC, ETA_PERIOD3 = "0.70", "0.712", "0.74"

#: float64's unit roundoff doubled (numpy's machine epsilon).
EPS = float(np.finfo(float).eps)


def paper(eta: str = ETA_CHAOTIC, **values) -> pi.Params:
    """The paper's system at ``eta`` (other parameters replaced by ``values``)."""
    return pi.Params.make(eta=eta, **values)


def non_impacting(eta: str = "0.5") -> pi.Params:
    """A system whose steady state never reaches the wall (x_w = 1000): linear, LLE = -zeta."""
    return pi.Params.make(eta=eta, x_w="1000")


def forcing_period(params: pi.Params) -> float:
    return 2 * math.pi / float(params.eta)


def exponent_sum(params: pi.Params, impacts: int, time: float) -> float:
    """The exact sum of both Lyapunov exponents over ``time`` with ``impacts`` impacts.

    Between impacts the flow's determinant is exp(-2 zeta tau); each saltation matrix
    [[-R, 0], [*, -R]] has determinant R^2.  So sum = -2 zeta + (impacts / time) ln R^2,
    exactly, chaotic or not: an identity every tangent integrator must reproduce.
    """
    return -2 * float(params.zeta) + impacts / time * math.log(float(params.R) ** 2)


def check_accuracy_outputs(out, stdout: str) -> None:
    """What ``precise-impact accuracy --out OUT`` leaves: a table on stdout, accuracy.json and
    a plot; every reference demonstrated (< 1e-40), heyoka float64 and the compiled engine at
    float64 accuracy on the periodic case (tests/cli/test_cli.py's run and the README's)."""
    out = Path(out)
    assert "reference" in stdout
    res = json.loads((out / "accuracy.json").read_text())
    assert (out / "accuracy.png").stat().st_size > 10_000
    refs = [row for row in res["rows"] if row["role"] != "candidate"]
    assert len(refs) == 3 and all(row["max_error"] < 1e-40 for row in refs)
    f64 = {
        row["eta"]: row["max_error"]
        for row in res["rows"]
        if row["model"] == "heyoka" and row["precision"] == "float64"
    }
    assert f64["0.74"] < 1e-12
    fast = {row["eta"]: row["max_error"] for row in res["rows"] if row["model"] == "fast"}
    assert fast["0.74"] < 1e-12  # the compiled engine scored like every model: float64 accuracy
