"""``precise-impact impact-map`` and ``singularity``: JSON, --out files, bad input exit 2."""

from __future__ import annotations

import json

import pytest

from precise_impact.cli.main import main


def test_impact_map_json_and_out(tmp_path, capsys):
    out = tmp_path / "o"
    args = ["impact-map", "--eta", "0.74", "--n", "12", "--transient", "2", "--engine", "heyoka"]
    assert main([*args, "--json", "--out", str(out)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert len(d["events"]) == 12 and {e["kind"] for e in d["events"]} == {"impact"}
    assert all(0 <= e["phase"] < 1 and e["v"] > 0 for e in d["events"])
    on_disk = json.loads((out / "impact_map.json").read_text())
    assert on_disk["events"] == d["events"]
    assert (out / "impact_map.png").stat().st_size > 1000


def test_singularity_json_and_out(tmp_path, capsys):
    out = tmp_path / "s"
    args = ["singularity", "--eta", "0.712", "--orbit", "50", "--step", "0.02"]
    assert main([*args, "--json", "--out", str(out)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["branches"] and d["max_step"] <= 0.02 * 1.01
    assert (out / "singularity.png").stat().st_size > 1000


@pytest.mark.parametrize(
    "args, name",
    [
        (["impact-map", "--phase", "1.5"], "phase"),
        (["impact-map", "--v", "-1"], "v"),
        (["impact-map", "--n", "0"], "n"),
        (["impact-map", "--n", "5", "--transient", "5"], "transient"),
        (["singularity", "--step", "0.5"], "step"),
        (["singularity", "--v-max", "0"], "v-max"),
    ],
)
def test_bad_input_exit_2(args, name, capsys):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert name in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
