"""The degradation benchmark of the capture scores: its committed results are what the docs
say, and (slow) a quick run still meets issue 24's figures at the bench."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "bench_capture_degradation.py"
RESULTS = ROOT / "benchmarks" / "results" / "capture_degradation.json"
DOC = ROOT / "docs" / "guide" / "capture_degradation.inc"
pytestmark = pytest.mark.skipif(not SCRIPT.is_file(), reason="needs the checkout's benchmarks/")


def _bench():
    spec = importlib.util.spec_from_file_location("bench_capture_degradation", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_docs_text_is_generated_from_the_committed_results():
    data = json.loads(RESULTS.read_text(encoding="utf-8"))
    assert DOC.read_text(encoding="utf-8") == _bench().degradation_rst(data), (
        "docs/guide/capture_degradation.inc is stale: rerun the benchmark"
    )
    base = next(r for r in data["rows"] if r["axis"] == "bits" and r["bits"] == 8)
    assert base["freq_err_v3"] < 1e-4 and base["freq_err_vs"] < 1e-4
    assert base["period3_rate"] == 1 and base["false_period_rate"] == 0
    assert base["sep_ratio_074"] > 2 and base["same_ratio_074"] <= 2


@pytest.mark.slow
def test_quick_run_meets_the_bench_figures(tmp_path):
    assert _bench().main(["--quick", "--seeds", "1", "--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "capture_degradation.json").read_text())
    base = next(r for r in data["rows"] if r["bits"] == 8 and r["noise"] == 0.01)
    assert base["freq_err_v3"] < 1e-4 and base["period3_rate"] == 1
    assert base["false_period_rate"] == 0 and base["sep_ratio_074"] > 2
    for name in ("capture_degradation.md", "capture_degradation.png"):
        assert (tmp_path / name).stat().st_size > 0
