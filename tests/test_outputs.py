"""Outputs other tools can load (issue 27, item 4): strict JSON, Markdown tables that render,
CSV columns that read as numbers."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import pytest

import precise_impact as pi
from precise_impact.io.markdown import parse_tables, table

SRC = Path(pi.__file__).parent


def strict_loads(text: str):
    """Parse refusing the NaN / Infinity / -Infinity tokens Python's parser accepts."""

    def refuse(token):
        raise AssertionError(f"non-strict JSON token {token}")

    return json.loads(text, parse_constant=refuse)


def assert_tables_render(text: str, expect: int | None = None) -> list:
    """Every pipe table in ``text`` has as many delimiter and body cells as header cells."""
    tables = parse_tables(text)  # raises on a mismatch
    if expect is not None:
        assert len(tables) == expect, [t[0] for t in tables]
    for t in tables:
        assert len(t) >= 2, t  # a header and at least one row
    return tables


# ----------------------------------------------------------------------- Markdown
def test_markdown_table_writer_and_parser():
    lines = table(("a", "b|c", "d"), [(1, "x|y", 2.5)], "lrc")
    assert lines == ["| a | b\\|c | d |", "|---|---:|:---:|", "| 1 | x\\|y | 2.5 |"]
    assert parse_tables("\n".join(lines)) == [[["a", "b|c", "d"], ["1", "x|y", "2.5"]]]
    with pytest.raises(ValueError, match="row 0 has 2 cells for 3"):
        table(("a", "b", "c"), [(1, 2)])
    # the defect of compare's chaotic table: 13 header cells, 14 delimiter cells
    bad = "| " + " | ".join("h" * 13) + " |\n|---|" + "---:|" * 13 + "\n"
    with pytest.raises(ValueError, match="14 delimiter cells for 13 header cells"):
        parse_tables(bad)
    with pytest.raises(ValueError, match="3 cells for 2 header cells"):
        parse_tables("| a | b |\n|---|---|\n| 1 | 2 | 3 |\n")


def test_every_markdown_table_comes_from_the_one_writer():
    """No hand-written delimiter row anywhere in the package but in io/markdown.py."""
    offenders = [
        str(p.relative_to(SRC))
        for p in SRC.rglob("*.py")
        if p.name != "markdown.py" and ("|---" in p.read_text() or '"| ' in p.read_text())
    ]
    assert offenders == []


def _points(model: float, shift: float, how: str = "root") -> dict:
    d = {"model": model, "shift": shift, "resolution": 1e-6, "how": how}
    if how == "extrapolated":
        d.update(lost=(0.9, 0.91), test_at_last_valid=0.25)
    return d


@pytest.mark.slow  # ~9 s: the CLI's start, the mp reference and its LLE
def test_compare_outputs_load_in_other_tools(tmp_path):
    """``compare`` through the CLI on the chaotic scene with the switched-capacitor model (its
    NaN impact velocities gave a NaN impact-v W1; 13 header cells vs 14 delimiter cells):
    scores.json loads with a strict parser and every report table renders; the periodic
    report and the grazing / period-doubling table too."""
    out = tmp_path / "chaotic"
    r = subprocess.run(
        [sys.executable, "-m", "precise_impact", "compare", "fig5-chaotic-ideal"]
        + ["--models", "switched-capacitor", "--periods", "12", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    scores = strict_loads((out / "scores.json").read_text())
    sc = scores["models"]["switched-capacitor"]
    assert isinstance(sc["impact_v_wasserstein"], float)  # was NaN (null): no velocities
    for m in scores["models"].values():  # a null score says why (12 periods: no growth fit)
        for part in (m["divergence"], m.get("model_lle_fit") or {}):
            assert part["rate"] is not None or "3 needed" in part["why"]
    (t,) = assert_tables_render((out / "report.md").read_text(), expect=1)
    assert len(t[0]) == 1 + len(sc["horizons"]) + 9 and t[1][0] == "switched-capacitor"

    # the periodic table and the grazing / period-doubling table (compare --points: 1-10 s
    # a model) laid out from real periodic scores of two models on this result
    from precise_impact.verification.compare import report_markdown
    from precise_impact.verification.scores import score

    p = pi.Params.make(eta="0.74")
    ref = pi.simulate(p, 20, precision="mp:128")
    d = json.loads((out / "scores.json").read_text())
    d["regime"] = "periodic"
    for m in ("heyoka", "analytical"):
        tr = pi.simulate(p, 20, model=m)
        d["models"][m] = score(tr, ref, regime="periodic", lle=-0.05, transient=4)
        d["models"][m].update(effects=[], effects_dropped=[])
    del d["models"]["switched-capacitor"]
    (t,) = assert_tables_render(report_markdown(d), expect=1)
    assert len(t) == 3 and len(t[0]) == 10
    d["reference"]["points"] = {"grazing": 0.9, "period-doubling": None}
    d["models"]["heyoka"]["points"] = {
        "grazing": _points(0.9, 1e-9),
        "period-doubling": _points(0.95, 2e-3, "extrapolated"),
    }
    d["models"]["analytical"]["points"] = {"grazing": _points(0.9, 0.0), "period-doubling": None}
    tables = assert_tables_render(report_markdown(d), expect=2)
    assert len(tables[1][0]) == 8 and tables[1][2][4:] == ["n/a"] * 4


# ----------------------------------------------------------------------- CSV
def test_sweep_csv_reads_as_numbers(tmp_path):
    """``sweep.csv`` wrote coordinates as exact ratios (``0.7 + 0.02/3 = 53/75``... ``89/58``),
    which spreadsheets and pandas read as text; now decimal floats, the exact value in
    ``NAME_exact``."""
    base = pi.Params.make()
    spec = pi.SweepSpec.make(
        base, [("eta", "0.7", "0.72", 4), ("R", "0.8", "0.9", 2)], periods=5, transient=5
    )
    res = pi.run_sweep(spec, tmp_path, workers=1, progress=False)
    with open(tmp_path / "sweep.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 8
    numeric = ("eta", "R", "lle", "stderr", "lambda2", "period", "impacts_per_period")
    assert list(rows[0]) == [*numeric, "status", "eta_exact", "R_exact"]
    assert any("/" in r["eta_exact"] for r in rows)  # the grid has non-terminating values
    for r in rows:
        vals = {k: float(r[k]) for k in numeric}  # every numeric column reads as a number
        assert vals["eta"] == float(Fraction(r["eta_exact"]))
        assert vals["R"] == float(Fraction(r["R_exact"]))
        assert r["status"] == "ok"
    assert [float(r["lle"]) for r in rows] == [float(v) for v in res.lle.ravel()]
    pd = pytest.importorskip("pandas")
    df = pd.read_csv(tmp_path / "sweep.csv")
    for k in numeric:
        assert pd.api.types.is_numeric_dtype(df[k]), k
    assert df["eta"].iloc[2] == float(Fraction("0.7") + Fraction("0.02") / 3)  # exact float


# ----------------------------------------------------------------------- the model registry
def test_every_registered_model_is_accepted_wherever_models_are_listed():
    """Every list of models derives from the registry: ``compare --models`` took 5 of the 8,
    ``accuracy`` scored 4, scenes ran 5.  Each model runs a scene (in a precision it takes:
    certified in mp at the reference's bits, without dense output) and is named in the help
    of every command that takes a model."""
    import argparse
    import dataclasses

    from precise_impact.cli.main import build_parser
    from precise_impact.models.circuit.spice import find_ngspice
    from precise_impact.verification.accuracy import candidates
    from precise_impact.verification.compare import check_models, scene_for_model
    from precise_impact.verification.metrics import reference_bits

    names = list(pi.MODELS)
    assert len(names) >= 8  # heyoka, analytical(-paper), fast, certified, 3 circuit models
    assert check_models(",".join(names)) == names
    assert check_models(["mechanical"]) == ["heyoka"]  # the alias
    assert {m for m, _ in candidates(reference_bits(30))} == set(names)
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for cmd, flag in (("compare", "--models"), ("run", "--model"), ("simulate", "--model")):
        text = " ".join(a.help or "" for a in sub.choices[cmd]._actions if flag in a.option_strings)
        assert all(m in text for m in names), (cmd, text)
    try:
        find_ngspice()
        have_spice = True
    except pi.OptionalDependencyError:
        have_spice = False
    scene = pi.load_scene("fig5-chaotic-datasheet")  # switched-capacitor, datasheet effects
    for m in names:
        fitted, dropped = scene_for_model(scene, m, 20)
        assert fitted.model == m
        caps = pi.solvers.base.model_capabilities(m)
        assert fitted.precision.kind in caps.precisions
        assert fitted.per_period == (50 if caps.dense else 0)
        if m == "spice" and not have_spice:
            continue
        tr = pi.run_scene(dataclasses.replace(fitted, periods=3))
        assert tr.model == m and len(tr.t) == 4, m
    with pytest.raises(pi.ParameterError, match="models"):
        check_models("heyoka,nonesuch")


def test_trajectory_csv_reads_as_numbers(tmp_path):
    """``simulate --out FILE.csv``: the impact rows' x (the wall) was ``17/9`` for a wall that
    is no terminating decimal; every number column now reads with float()."""
    tr = pi.simulate(pi.Params.make(eta="0.74", x_w="17/9"), 3)
    with open(tr.save(tmp_path / "a.csv"), newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["kind"] for r in rows].count("impact") == tr.n_impacts > 0
    for r in rows:
        for k in ("t", "x", "v_or_v_before") + (("v_after",) if r["kind"] == "impact" else ()):
            float(r[k])
    wall = [float(r["x"]) for r in rows if r["kind"] == "impact"]
    assert wall == [float(Fraction(17, 9))] * tr.n_impacts


def test_a_null_score_says_why():
    """Strict JSON writes NaN as null: the scores that can be undefined carry a reason."""
    from precise_impact.io.jsonout import dumps
    from precise_impact.verification.scores import divergence_rate

    d = strict_loads(dumps(divergence_rate([0.0, 1.0, 2.0], [1e-20, 1e-20, 1e-20])))
    assert d["rate"] is None and d["why"].startswith("no fit: 0 samples")
    ok = divergence_rate([0.0, 1.0, 2.0, 3.0], [1e-10, 1e-9, 1e-8, 1e-7])
    assert math.isclose(ok["rate"], math.log(10), rel_tol=1e-12) and "why" not in ok
