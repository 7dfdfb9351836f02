"""Work-precision benchmark (precise_impact.verification.workprecision): a tiny run's structure and
sanity."""

from __future__ import annotations

import math

import pytest

from precise_impact import Params
from precise_impact.solvers.heyoka.single import HeyokaSolver
from precise_impact.verification.workprecision import predicted_bits, scipy_solve, work_precision

TINY = {
    "cases": {
        "periodic": {"eta": "0.74", "periods": 10},
        "chaotic": {"eta": "0.712", "periods": 10},
    },
    "heyoka": {"float64": ["1e-5", "1e-9", None]},
    "heyoka_mp": [],
    "analytical_paper": [],
    "analytical_robust": True,
    "analytical_mp_dps": [],
    "scipy": {"DOP853": [1e-8]},
    "spice_tmax": [],
    "chaos_N": [10, 40, 80],
    "certify_N": 40,
    "budget_s": 0.5,
    "circuit": False,
}


@pytest.fixture(scope="session")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("wp")
    return work_precision(quick=True, out=out, progress=False, config=TINY), out


def test_structure_and_outputs(tiny):
    res, out = tiny
    for key in ("references", "rows", "chaos_cost", "headlines", "notes"):
        assert key in res
    for name in (
        "work_precision.json",
        "work_precision.csv",
        "work_precision.png",
        "chaos_cost.png",
    ):
        assert (out / name).stat().st_size > 0
    for r in res["rows"]:
        assert r["time_s"] > 0 and r["repeats"] >= 1 and math.isfinite(r["error"])
        if r["family"].startswith("heyoka"):
            assert r["compile_s"] is not None


def test_reference_agreement_demonstrated(tiny):
    res, _ = tiny
    for case, ref in res["references"].items():
        assert ref["check"] != ref["precision"]
        assert ref["agreement"] < 1e-30, case


def test_heyoka_error_decreases_with_tolerance(tiny):
    res, _ = tiny
    for case in ("periodic", "chaotic"):
        rows = [r for r in res["rows"] if r["case"] == case and r["family"] == "heyoka float64"]
        errs = [r["error"] for r in rows]  # tolerances 1e-5, 1e-9, eps in order
        assert len(errs) == 3
        assert errs[0] > errs[1] > errs[2] or errs[2] < 1e-12, (case, errs)
        assert errs[0] > 10 * errs[2]


def test_chaos_cost_bits_increase(tiny):
    res, _ = tiny
    rows = res["chaos_cost"]["rows"]
    bits = [r["bits"] for r in rows]
    assert bits == sorted(bits) and bits[-1] > bits[0]
    pred = [r["predicted_bits"] for r in rows]
    assert all(b < c for b, c in zip(pred, pred[1:], strict=False))
    assert predicted_bits(300) > predicted_bits(50)
    assert res["chaos_cost"]["certify"]["certified"]


def test_scipy_first_impact_time():
    pytest.importorskip("scipy", reason="scipy not installed (optional 'bench' extra)")
    p = Params.make(eta="0.74")
    ref = HeyokaSolver("float64").solve(p, 5)
    assert ref.n_impacts >= 1
    t_ref = float(ref.impacts_t[0])
    for rtol in (1e-6, 1e-10):
        res = scipy_solve(p, 5, "DOP853", rtol)
        assert len(res.impacts_t) >= 1
        # measured: 2.4e-7 at rtol 1e-6, 1.7e-11 at rtol 1e-10 (atol = rtol * 1e-3)
        assert abs(res.impacts_t[0] - t_ref) < 10 * rtol, (rtol, res.impacts_t[0], t_ref)


def test_the_bench_table_prints_from_the_result(tiny, tmp_path):
    """``bench work-precision`` without --json printed a traceback after its run
    (``'WorkPrecisionResult' object has no attribute 'get'``): the table is made from the result
    and from its JSON form alike, and the JSON file is strict."""
    import dataclasses
    import json

    from precise_impact.verification.workprecision import format_table

    res, out = tiny
    text = format_table(res)
    assert "Headlines:" in text and "periodic: eta=0.74" in text
    assert format_table({f.name: getattr(res, f.name) for f in dataclasses.fields(res)}) == text

    def refuse(token):
        raise AssertionError(token)

    json.loads((out / "work_precision.json").read_text(), parse_constant=refuse)
