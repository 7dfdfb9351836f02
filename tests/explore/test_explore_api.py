"""The explorer's views against independent facts: period 3 at eta = 0.74 (the paper's Fig. 6),
a non-impacting orbit's LLE = -zeta, the circuit's units as the circuit model maps them, and
strict JSON throughout."""

from __future__ import annotations

import json

import pytest

from precise_impact.explore import api
from precise_impact.explore.state import State


def _strict(d: dict) -> dict:
    def bad(token):
        raise ValueError(f"non-strict JSON token {token}")

    return json.loads(json.dumps(d, allow_nan=False), parse_constant=bad)


def test_orbit_at_074_is_period_3_with_two_impacts():
    got = _strict(api.orbit(State.from_query({"eta": "0.74", "transient": "600", "periods": "30"})))
    assert got["period"] == 3
    assert got["impacts_per_period"] == pytest.approx(2 / 3)  # two impacts per 3 periods
    assert len(got["strobe"]["x"]) == 31 and len(got["curve"]["t"]) >= 30 * api.DENSE_PER_PERIOD
    assert max(got["curve"]["x"]) <= 2.0 + 1e-12  # the wall at x_w = 2


def test_non_impacting_orbit_has_lle_minus_zeta():
    """Far below the grazing frequency the orbit never reaches the wall: LLE = -zeta exactly
    (the flow contracts at the damping rate); the error bar must cover it."""
    got = _strict(api.lle(State.from_query({"eta": "0.3", "x_w": "50"})))
    assert abs(got["lle"] + 0.05) <= max(3 * got["stderr"], 1e-9)


def test_circuit_units_are_the_circuit_models():
    """R = 10 kOhm, C = 100 nF: omega = 1000 rad/s, so one unit of time is 1 ms; the node
    voltage is V_s = -x volts (CircuitSolver's start ``Vs0 = -x0 V_unit``)."""
    c = api.orbit(State.from_query({"eta": "0.74", "periods": "2"}))["circuit"]
    assert c["available"] and c["seconds_per_unit_time"] == pytest.approx(1e-3, rel=1e-15)
    assert c["volts_per_unit_x"] == -1.0
    z = api.orbit(State.from_query({"eta": "0.74", "zeta": "0", "periods": "2"}))["circuit"]
    assert not z["available"]


def test_bifurcation_slice_has_period_3_inside_the_fig6_window():
    got = _strict(
        api.bifurcation(
            State.from_query({"eta_min": "0.74", "eta_max": "0.75", "n": "3", "bif_periods": "30"})
        )
    )
    assert len(got["eta"]) == 3 and all(len(row) == 30 for row in got["x"])
    distinct = {round(x, 6) for x in got["x"][0]}
    assert len(distinct) == 3  # period 3 at eta = 0.74


def test_basins_rows_arrive_and_make_the_labelled_map():
    """The view's rows arrive one by one (each row once); the labels cover the grid."""
    rows: list[dict] = []
    chatter = State.from_query({"eta": "4.85", "zeta": "0", "R": "0.5", "x_w": "-0.3",
                                "x0": "-0.5"})  # fmt: skip
    got = _strict(api.basins(chatter, 6, 5, 0.6, on_tile=rows.append))
    assert len(rows) == 5 and sorted(i for r in rows for i in r["index"]) == list(range(30))
    assert len(got["labels"]) == 5 and all(len(r) == 6 for r in got["labels"])
    assert got["command"].startswith("precise-impact basins") and "--phase 0 1 6" in got["command"]


def test_the_ideal_circuit_model_overlays_the_mechanics_to_its_tolerance():
    """The paper's circuit with ideal components is the mechanics in other units: on the
    period-3 orbit its samples lie on the compiled engine's within the circuit model's
    integration tolerance (reproduce's report: below 1e-10 on Figs. 4 and 6)."""
    got = _strict(api.circuit(State.from_query({"eta": "0.74", "periods": "6", "transient": "30"})))
    assert got["model"] == "circuit" and len(got["strobe"]["x"]) == 7
    assert got["max_dx_shown"] < 1e-8, got["max_dx_shown"]
    assert len(got["curve"]["t"]) >= 6 * api.DENSE_PER_PERIOD


def test_the_impact_map_jumps_across_its_singularity_set():
    """A point of the singularity set is an impact whose next flight grazes the wall: the
    map is discontinuous there, so two starts 1e-5 apart on either side of the curve (in v)
    have next impacts far apart, while two starts 1e-5 apart away from it stay close."""
    s = State.from_query({"eta": "0.712"})
    got = _strict(api.impact_map(s, 0.3, 1.0, 50, singularity=True))
    assert got["singularity"] and "--singularity" in got["command"]
    for c in got["singularity"]:  # a curve never jumps across the figure (phase wraps 1 -> 0)
        steps = [abs(b - a) for a, b in zip(c["phase"][:-1], c["phase"][1:], strict=True)]
        assert max(steps, default=0) < 0.5, c["phase"]
    curve = max(got["singularity"], key=lambda c: len(c["phase"]))
    i = len(curve["phase"]) // 2
    ph, v = curve["phase"][i], curve["v"][i]

    def next_phase(dv):
        return api.impact_map(s, ph, v + dv, 2)["phase"][1]

    jump = abs(next_phase(1e-5) - next_phase(-1e-5))
    assert min(jump, 1 - jump) > 1e-3, (ph, v, jump)


def test_each_views_csv_holds_its_numbers():
    """The CSV of a view (the page's download) parses back to the view's numbers, row for
    row (floats as their shortest round-trip text)."""
    import csv
    import io

    s = State.from_query({"eta": "0.74", "periods": "6", "transient": "30"})
    orbit = api.orbit(s, full=False)
    rows = list(csv.DictReader(io.StringIO(api.view_csv(orbit))))
    strobe = [r for r in rows if r["kind"] == "strobe"]
    assert [float(r["x"]) for r in strobe] == orbit["strobe"]["x"]
    assert sum(r["kind"] == "impact" for r in rows) == len(orbit["impacts"]["t"])
    bif = api.bifurcation(State.from_query({"eta_min": "0.74", "eta_max": "0.75", "n": "3",
                                            "bif_periods": "5"}))  # fmt: skip
    rows = list(csv.DictReader(io.StringIO(api.view_csv(bif))))
    assert len(rows) == 3 * 5 and float(rows[-1]["x"]) == bif["x"][-1][-1]
    chatter = State.from_query({"eta": "4.85", "zeta": "0", "R": "0.5", "x_w": "-0.3",
                                "x0": "-0.5"})  # fmt: skip
    basins = api.basins(chatter, 4, 3, 0.6)
    rows = list(csv.DictReader(io.StringIO(api.view_csv(basins))))
    assert len(rows) == 12 and float(rows[0]["phase"]) == 0.125  # the first cell's centre
    assert [int(r["label"]) for r in rows[:4]] == basins["labels"][0]
