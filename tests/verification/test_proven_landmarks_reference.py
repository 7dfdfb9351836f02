"""The ``landmarks`` reference case (issue 26 item 3): proven intervals, re-proven on verify."""

from __future__ import annotations

import json
import shutil
from fractions import Fraction

import pytest

from precise_impact.cli.main import main as cli_main
from precise_impact.verification.proven_landmarks import LANDMARKS_FILE
from precise_impact.verification.reference import (
    default_root,
    read_manifest,
    verify,
    write_manifest,
)

ROOT = default_root()
CASE = "landmarks"


def _rows(root):
    return json.loads((root / CASE / LANDMARKS_FILE).read_text())["landmarks"]


def test_shipped_landmarks_are_proven_and_reprove():
    rows = {r["name"]: r for r in _rows(ROOT)}
    assert set(rows) == {"grazing", "pd_1_1", "p3_low", "p3_high"}
    for r in rows.values():
        width = Fraction(r["eta_upper"]) - Fraction(r["eta_lower"])
        assert 0 < width <= Fraction(r["requested_width"])
        assert [s["sign"] for s in r["sides"]] in ([-1, 1], [1, -1])
    assert Fraction(rows["grazing"]["requested_width"]) == Fraction(1, 10**40)
    assert rows["grazing"]["closed_form_inside"] is True
    assert verify(ROOT, cases=[CASE]) == []
    assert cli_main(["reference", "verify", "--case", CASE]) == 0


def _forge(tmp_path, change):
    copy = tmp_path / "ref"
    shutil.copytree(ROOT / CASE, copy / CASE)
    p = copy / CASE / LANDMARKS_FILE
    data = json.loads(p.read_text())
    change({r["name"]: r for r in data["landmarks"]})
    p.write_text(json.dumps(data, indent=1) + "\n")
    m = read_manifest(copy / CASE)  # re-checksummed: only the re-proof can catch it
    write_manifest(copy / CASE, list(m["files"]), {k: v for k, v in m.items() if k != "files"})
    return verify(copy, cases=[CASE])


def test_a_shifted_interval_is_caught_by_the_reproof(tmp_path):
    def shift(rows):  # the 1:1 period doubling moved by 1e-20 (far above its width 2e-56)
        r = rows["pd_1_1"]
        for k in ("eta_lower", "eta_upper"):
            r[k] = str(Fraction(r[k]) + Fraction(1, 10**20))

    problems = _forge(tmp_path, shift)
    assert problems and "pd_1_1" in problems[0] and "misses the re-proven" in problems[0]


@pytest.mark.parametrize("what", ["width", "closed form"])
def test_a_widened_or_wrong_grazing_is_caught(tmp_path, what):
    def widen(rows):
        r = rows["grazing"]
        if what == "width":  # an interval wider than the requested 1e-40
            r["eta_upper"] = str(Fraction(r["eta_upper"]) + Fraction(1, 10**39))
        else:  # still narrow, overlapping nothing true: the closed form outside
            r["eta_lower"] = str(Fraction(r["eta_lower"]) + Fraction(1, 10**50))
            r["eta_upper"] = str(Fraction(r["eta_upper"]) + Fraction(1, 10**50))

    problems = _forge(tmp_path, widen)
    assert problems and all("grazing" in q for q in problems)
    assert any(("above requested" if what == "width" else "closed form") in q for q in problems)
