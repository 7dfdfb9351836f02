"""sync_scan through the scan runner: the k axis tuple, model=, workers and progress."""

from __future__ import annotations

import pytest

from precise_impact import Params
from precise_impact.analysis.sync import sync_scan

KW = dict(periods=120, ensemble=3, lle_periods=0)


def _numbers(r):
    d = r.to_dict()
    d.pop("elapsed_s")
    return d


def test_k_axis_workers_and_model_give_the_same_scan():
    """('k', start, stop, n) is the list of its exact values; 2 processes and model= give
    the serial engine= numbers bit for bit (engine= warns naming model=)."""
    p = Params.make()
    ref = sync_scan(p, "first-order", ["0", "0.03", "0.06"], **KW)
    assert list(ref.fraction_synchronised) == [0.0, 0.0, 1.0]  # k = 0.06 > LLE ~ 0.03
    axis = sync_scan(p, "first-order", ("k", "0", "0.06", 3), workers=2, model="fast", **KW)
    assert _numbers(axis) == _numbers(ref)
    with pytest.warns(DeprecationWarning, match="model="):
        old = sync_scan(p, "first-order", ["0", "0.03", "0.06"], engine="fast", **KW)
    assert _numbers(old) == _numbers(ref)


def test_progress_meanings(capsys):
    """True: one line per k on stderr; None off a terminal and False: silent; a callable:
    (k done, k total)."""
    p = Params.make()
    sync_scan(p, "reduced", ["0", "0.05"], progress=True, **KW)
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(":")[0] for line in lines] == ["  sync reduced k=0", "  sync reduced k=0.05"]
    for quiet in (None, False):
        sync_scan(p, "reduced", ["0.05"], progress=quiet, **KW)
        assert capsys.readouterr().err == ""
    seen = []
    sync_scan(p, "reduced", ["0", "0.05"], progress=lambda d, n: seen.append((d, n)), **KW)
    assert seen == [(1, 2), (2, 2)] and capsys.readouterr().err == ""


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"k_values": ("k", "0", "0.1", 0)}, "n"),
        ({"model": "gpu"}, "model"),
        ({"model": "fast", "precision": "mp:128"}, "precision"),
        ({"workers": 0}, "workers"),
        ({"progress": "yes"}, "progress"),
        # the hypothesis fuzz (CI, 2026-11-26): spread 1.8e-100 gave a slave start of 1.2e-104,
        # refused naming y0[1]; the spread's range now keeps every start admissible
        ({"spread": "1.8208573495346153e-100"}, "spread"),
        ({"spread": "1e95"}, "spread"),
    ],
)
def test_validation(kwargs, name):
    from precise_impact import ParameterError

    args = {"params": Params.make(), "form": "first-order", "k_values": ["0.03"], **KW}
    args.update(kwargs)
    with pytest.raises(ParameterError) as e:
        sync_scan(**args)
    assert e.value.name == name
