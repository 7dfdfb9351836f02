"""Domains of attraction: labels against long single runs, executors, resume, bad input."""

from __future__ import annotations

import importlib.util
import json

import numpy as np
import pytest

import precise_impact as pi
from precise_impact.analysis.impact_surface.basins import (
    SAME_ORBIT,
    basins,
    clear_caches,
    point_attractor,
    same_impact,
)
from precise_impact.errors import ParameterError

CHATTER = pi.Params.make(eta="4.85", zeta=0, R="0.5", x_w="-0.3", x0="-0.5")  # Budd-Dux
PAPER = pi.Params.make(eta="0.74")  # (2,3) and (16,16) coexist


def _same(a: dict, b: dict) -> bool:
    """Two independent identifications name the same attractor (periodic: same (m, n) and the
    same refined fastest impact to SAME_ORBIT; Newton leaves both at rounding level)."""
    if a["kind"] != b["kind"]:
        return False
    if a["kind"] != "periodic":
        return True
    return (a["impacts"], a["period"]) == (b["impacts"], b["period"]) and same_impact(
        a["rep_phase"], a["rep_v"], b["rep_phase"], b["rep_v"], SAME_ORBIT
    )


def _agreement(params, grid, transient, n_sample, seed):
    r = basins(params, grid, transient=transient, progress=False)
    cu, cv = r.coordinates()
    clear_caches()  # the long runs refine every cycle again, from scratch
    rng = np.random.default_rng(seed)
    picks = rng.choice(r.labels.size, size=min(n_sample, r.labels.size), replace=False)
    away = disagree = 0
    for k in picks:
        i, j = np.unravel_index(k, r.labels.shape)
        long = point_attractor(params, r.section, cu[j], cv[i], transient=10 * transient)
        att = r.attractors[r.labels[i, j]]
        mine = {
            "kind": att["kind"], "impacts": att["impacts"], "period": att["period"],
            "rep_phase": att["phase"], "rep_v": att["v"],
        }  # fmt: skip
        if not r.boundary[i, j]:
            away += 1
            disagree += not _same(mine, long)
    return r, away, disagree


def test_chatter_map_agrees_with_long_runs():
    # 40 x 40 on the Budd-Dux chatter case, 100 random points re-run with 10x the transient
    r, away, disagree = _agreement(CHATTER, ((0, 1, 40), (0, 0.6, 40)), 60, 100, 1)
    assert disagree == 0 and away == 100
    assert [a["name"] for a in r.attractors] == ["chatter + sticking"]
    assert r.stuck.all() and (r.capture > 0).all()
    json.dumps(r.to_dict(), allow_nan=False)


def test_paper_map_agrees_with_long_runs():
    # two coexisting periodic attractors: every point away from the boundary agrees
    # measured: 73 of 100 sampled away from the boundary, 0 disagreements, boundary fraction 0.32
    r, away, disagree = _agreement(PAPER, ((0, 1, 40), (0, 3, 40)), 100, 100, 3)
    names = sorted(a["name"] for a in r.attractors)
    assert "(2,3) stable" in names
    assert disagree == 0 and away >= 50
    assert 0 < r.stats["boundary_fraction"] < 0.5


def test_one_orbit_one_label_and_exact_floquet_lle():
    r = basins(PAPER, ((0, 1, 6), (0.5, 2.5, 4)), transient=100, refine=False, progress=False)
    per = [a for a in r.attractors if a["kind"] == "periodic"]
    assert len({(a["impacts"], a["period"], round(a["v"], 6)) for a in per}) == len(per)
    o = pi.find_orbit(PAPER, 3)  # the (2,3) orbit: its LLE is ln|mu| / (3 T) from find_orbit
    (two_three,) = [a for a in per if (a["impacts"], a["period"]) == (2, 3)]
    assert two_three["lle"] == pytest.approx(o.lle, rel=1e-9)  # Newton to rounding either way


def test_stroboscopic_section_same_attractors_and_outside():
    r = basins(PAPER, ((1.0, 3.0, 4), (-1, 1, 3)), section="stroboscopic", transient=100,
               refine=False, progress=False)  # fmt: skip
    assert (r.labels[:, 2:] == -1).all()  # x = 2.25, 2.75 > x_w = 2: outside
    assert (r.labels[:, :2] >= 0).all()
    impact = basins(PAPER, ((0, 1, 6), (0.5, 2.5, 4)), transient=100, refine=False, progress=False)
    names = {a["name"] for a in impact.attractors}
    assert {a["name"] for a in r.attractors} <= names | {"unresolved"}


def test_resume_is_bit_identical(tmp_path):
    g = ((0, 1, 8), (0, 0.6, 5))  # 40 points, tiles of 7: 6 tiles
    with pytest.raises(ParameterError, match="max_tiles"):  # a partial run keeps its tiles
        basins(CHATTER, g, transient=40, tile_size=7, out=tmp_path, max_tiles=2, progress=False)
    assert len(list((tmp_path / "tiles_main" / "tiles").glob("*.npz"))) == 2
    a = basins(CHATTER, g, transient=40, tile_size=7, out=tmp_path, progress=False)
    assert a.stats["tiles_computed"] == 4  # the 2 finished tiles were reused
    b = basins(CHATTER, g, transient=40, tile_size=7, out=tmp_path, progress=False)
    assert b.stats["tiles_computed"] == 0
    c = basins(CHATTER, g, transient=40, tile_size=7, progress=False)  # no store at all
    for r in (b, c):
        assert np.array_equal(a.labels, r.labels) and np.array_equal(a.capture, r.capture)


@pytest.mark.skipif(importlib.util.find_spec("distributed") is None, reason="Dask is optional")
def test_dask_map_equals_serial(dask_scheduler):
    g = ((0, 1, 20), (0, 0.6, 20))
    a = basins(CHATTER, g, transient=40, tile_size=50, progress=False)
    # the session's LocalCluster of 2 worker processes (dask="local" started one per scan
    # basins makes: 5-11 s)
    b = basins(CHATTER, g, transient=40, tile_size=50, dask=dask_scheduler, workers=2,
               progress=False)  # fmt: skip
    assert b.stats["backend"] == "dask" and b.stats["workers"] == 2
    assert np.array_equal(a.labels, b.labels) and np.array_equal(a.capture, b.capture)


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"section": "poincare"}, "section"),
        ({"grid": ((0, 1, 4),)}, "grid"),
        ({"grid": ((0, 2, 4), (0, 1, 4))}, "grid"),
        ({"grid": ((1, 0, 4), (0, 1, 4))}, "phase"),
        ({"transient": 0}, "transient"),
    ],
)
def test_bad_input_names_the_parameter(kw, name):
    args = {"grid": ((0, 1, 4), (0, 1, 4))} | kw
    with pytest.raises(ParameterError, match=name):
        basins(CHATTER, **args, progress=False)


def test_cli_basins_json_and_resume(tmp_path, capsys):
    from precise_impact.cli.main import main

    argv = ["basins", "--eta", "4.85", "--zeta", "0", "--R", "0.5", "--x_w=-0.3", "--x0=-0.5",
            "--phase", "0", "1", "6", "--v", "0", "0.6", "5", "--transient", "30", "--tile", "7",
            "--out", str(tmp_path), "--json"]  # fmt: skip
    assert main(argv) == 0
    first = json.loads(capsys.readouterr().out)
    assert [a["name"] for a in first["attractors"]] == ["chatter + sticking"]
    assert (tmp_path / "basins.png").exists() and (tmp_path / "basins.json").exists()
    assert main(argv) == 0  # resumed: every tile from the store
    again = json.loads(capsys.readouterr().out)
    assert again["stats"]["tiles_computed"] == 0 and again["attractors"] == first["attractors"]


@pytest.mark.parametrize(
    "extra, code",
    [
        (["--section", "stroboscopic"], 2),
        (["--phase", "0", "1", "1000", "--max-time", "1"], 3),
        (["--subgrid", "1"], 2),
    ],
)
def test_cli_bad_input_and_budget_before_work(tmp_path, extra, code, capsys):
    from precise_impact.cli.main import main

    assert main(["basins", "--out", str(tmp_path), *extra]) == code
    assert capsys.readouterr().err.count("\n") == 1  # one line
    assert not (tmp_path / "basins.json").exists()


def test_chaotic_and_non_impacting_points():
    chaos = point_attractor(pi.Params.make(eta="0.712"), "stroboscopic", 0.0, 0.0,
                            chaos_periods=4000)  # fmt: skip
    assert chaos["kind"] == "chaotic"
    assert 0.02 < chaos["lle"] < 0.04  # the paper's LLE ~0.0302 over 4000 periods (3 sigma)
    lin = pi.Params.make(eta="0.5", x_w="1000")  # never reaches the wall: linear
    quiet = point_attractor(lin, "stroboscopic", 0.0, 0.0)
    assert quiet["kind"] == "non-impacting" and quiet["lle"] == -0.05  # -zeta, exactly


@pytest.mark.slow
def test_bigger_map_agrees_on_1000_points():
    # measured: 800 of the 1000 away from the boundary, 0 disagreements, boundary fraction 0.207
    r, away, disagree = _agreement(PAPER, ((0, 1, 100), (0, 3, 100)), 100, 1000, 3)
    assert disagree == 0 and away >= 700


@pytest.mark.slow
def test_ctrl_c_exits_130_and_keeps_finished_tiles(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "precise_impact", "basins", "--eta", "4.85", "--zeta", "0",
           "--R", "0.5", "--x_w=-0.3", "--x0=-0.5", "--phase", "0", "1", "1000", "--v", "0",
           "0.6", "1000", "--transient", "60", "--tile", "500", "--out", str(out)]  # fmt: skip
    p = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, stdin=subprocess.DEVNULL,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.default_int_handler),
    )  # fmt: skip
    deadline = time.time() + 60
    tiles = out / "tiles_main" / "tiles"
    while time.time() < deadline and len(list(tiles.glob("*.npz"))) < 2:
        time.sleep(0.2)
    assert p.poll() is None  # 2000 tiles of 500 points: far from done
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err[-500:]
    assert "Traceback" not in err
    kept = list(tiles.glob("*.npz"))
    assert len(kept) >= 2
    for f in kept:
        with np.load(f) as z:
            assert z["kind"].shape == (500,)


def test_subgrid_points_agree_with_long_single_runs():
    # 3 x 3 sub-points in every boundary cell of a 6 x 6 map at eta = 0.74, each checked against
    # an independent single run (caches cleared, 2x the sub-grid's transient of 100 x 10)
    g = ((0, 1, 6), (0, 3, 6))
    r = basins(PAPER, g, transient=100, subgrid=3, progress=False)
    n_cells = int(r.boundary.sum())
    assert n_cells > 0 and r.stats["subgrid"] == 3
    assert r.sub_u.size == r.sub_v.size == r.sub_label.size == 9 * n_cells
    assert r.stats["subgrid_points"] == 9 * n_cells and r.sub_agree.size == n_cells
    cu, cv = r.coordinates()
    du, dv = 1 / 6, 3 / 6
    for k in range(n_cells):  # the sub-points lie inside their own boundary cell
        i, j = np.unravel_index(np.flatnonzero(r.boundary.ravel())[k], r.boundary.shape)
        su, sv = r.sub_u[9 * k : 9 * k + 9], r.sub_v[9 * k : 9 * k + 9]
        assert (np.abs(su - cu[j]) < du / 2).all() and (np.abs(sv - cv[i]) < dv / 2).all()
    clear_caches()
    for u, v, lab in zip(r.sub_u, r.sub_v, r.sub_label, strict=True):
        long = point_attractor(PAPER, "impact", u, v, transient=2000)
        att = r.attractors[lab]
        mine = {
            "kind": att["kind"], "impacts": att["impacts"], "period": att["period"],
            "rep_phase": att["phase"], "rep_v": att["v"],
        }  # fmt: skip
        assert _same(mine, long), (u, v)
    per = r.sub_label.reshape(n_cells, 9)
    cells = r.labels.ravel()[r.boundary.ravel()]
    assert np.array_equal(r.sub_agree, (per == cells[:, None]).mean(axis=1))
    assert r.stats["mixed_cells"] == sum(len(set(p)) > 1 for p in per.tolist())
    d = r.to_dict()
    json.dumps(d, allow_nan=False)
    assert len(d["sub_label"]) == 9 * n_cells and r.tables() == ("attractors", "subgrid")
    assert len(r._tables()["subgrid"]()["phase [1]"]) == 9 * n_cells


def test_subgrid_off_is_identical():
    g = ((0, 1, 5), (0, 3, 4))
    a = basins(PAPER, g, transient=60, progress=False)
    b = basins(PAPER, g, transient=60, subgrid=0, progress=False)
    da, db = a.to_dict(), b.to_dict()
    for d in (da, db):
        d["stats"].pop("elapsed_s"), d["stats"].pop("time_per_point_s")
    assert da == db and db["sub_u"] == [] and db["stats"]["subgrid_points"] == 0


@pytest.mark.parametrize("bad", [1, -1, 100, "x", 2.5, True])
def test_bad_subgrid_names_the_parameter(bad):
    with pytest.raises(ParameterError, match="subgrid") as e:
        basins(PAPER, ((0, 1, 4), (0, 3, 4)), subgrid=bad, progress=False)
    assert str(e.value).count("\n") == 0


def test_on_tile_sees_every_point_once_and_can_stop_the_map():
    """``on_tile`` gets each tile of the first pass once, in this process: together their
    points are the grid, and their kinds are the map's before refinement; an exception it
    raises stops the map (the explorer's cancel)."""
    seen: list[dict] = []
    grid = ((0, 1, 6), (0.01, 0.6, 5))
    r = basins(CHATTER, grid, transient=30, tile_size=6, refine=False, progress=False,
               on_tile=lambda t, arrays: seen.append(arrays))  # fmt: skip
    assert len(seen) == 5
    index = np.concatenate([a["index"] for a in seen])
    assert sorted(index.tolist()) == list(range(30))
    kinds = np.empty(30)
    kinds[index] = np.concatenate([a["kind"] for a in seen])
    assert np.all(np.isfinite(kinds)) and r.labels.shape == (5, 6)

    class Stop(Exception):
        pass

    def stop(t, arrays):
        raise Stop

    with pytest.raises(Stop):
        basins(CHATTER, grid, transient=30, tile_size=6, progress=False, on_tile=stop)
