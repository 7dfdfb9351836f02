"""Readers and writers of oscilloscope capture files (generic CSV and NPZ; vendor layouts below)."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.errors import ParameterError
from precise_impact.io.atomic import atomic_write
from precise_impact.lab.capture import Capture

__all__ = ["read_capture", "write_capture", "WRITE_FORMATS"]

WRITE_FORMATS = ("csv", "npz")


def write_capture(capture: Capture, path: str | os.PathLike, fmt: str | None = None) -> Path:
    """Write ``capture`` to ``path`` in ``fmt`` (default by suffix: ``.npz``, ``.csv``)."""
    path = Path(path)
    fmt = fmt or path.suffix.lower().lstrip(".")
    if fmt == "npz":
        return capture.write_npz(path)
    if fmt == "csv":
        names = list(capture.channels)
        head = "time [s]," + ",".join(f"{n} [V]" for n in names)
        data = np.column_stack([capture.t] + [capture.channels[n] for n in names])

        def w(fh: Any) -> None:
            fh.write(head + "\n")
            np.savetxt(fh, data, delimiter=",", fmt=["%.10g"] + ["%.7g"] * len(names))

        atomic_write(path, w, binary=False)
        return path
    raise ParameterError("format", fmt, "one of " + ", ".join(WRITE_FORMATS))


def read_capture(path: str | os.PathLike, channels: Any = None) -> Capture:
    """Read a capture (generic time-first CSV with a header row, or NPZ)."""
    path = Path(path)
    if path.suffix.lower() == ".npz":
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"])) if "meta" in z else {}
            return Capture.make(
                z["t"],
                z["V_s"],
                z["V_q"],
                z["V_3"] if "V_3" in z else None,
                sample_interval=meta.get("sample_interval"),
                source=dict(meta.get("source", {}), path=str(path)),
                what=str(path),
            )
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return Capture.make(
        data[:, 0],
        data[:, 1],
        data[:, 2],
        data[:, 3] if data.shape[1] > 3 else None,
        source={"format": "csv", "path": str(path)},
        what=str(path),
    )
