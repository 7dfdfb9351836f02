"""The per-machine goldens: this machine's set is used, another machine's never."""

from __future__ import annotations

import json

import machine_goldens as mg
import pytest


def test_only_this_machines_values_are_compared(tmp_path, monkeypatch):
    path = tmp_path / "golden_x.json"
    mg.record(path, {"a": "f:1.0"})
    assert mg.cases(path) == {"a": "f:1.0"}
    entry = json.loads(path.read_text())["machines"][mg.machine_key()]
    assert entry["machine"] == mg.machine() and "precise_impact" in entry["source"]
    other = {**mg.machine(), "cpu": "another CPU"}
    monkeypatch.setattr(mg, "machine", lambda: other)
    with pytest.raises(pytest.skip.Exception, match="test_bitwise_x.py --regenerate"):
        mg.cases(path)
    mg.record(path, {"a": "f:2.0"})  # a second machine's set beside the first
    assert len(json.loads(path.read_text())["machines"]) == 2 and mg.cases(path)["a"] == "f:2.0"
