"""Writers of capture files in the instruments' own layouts (:data:`WRITE_FORMATS`).

Below :mod:`precise_impact.lab.capture` (they take any object with a capture's fields), so that
:meth:`~precise_impact.lab.capture.Capture.save` and
:func:`~precise_impact.lab.scope_files.write_capture` share them without an import cycle.
The layouts, and how the readers check them back: :doc:`/guide/captures`.
"""

from __future__ import annotations

import io
import os
import struct
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.errors import ParameterError, check_type
from precise_impact.io.atomic import atomic_write

__all__ = ["WRITE_FORMATS", "PRINT_MAX_ROUNDING", "write_layout"]

WRITE_FORMATS = ("csv", "npz", "rigol", "keysight", "tek-tbs", "tek", "siglent", "keysight-bin")
_LABELS = {"V_s": "CH1", "V_q": "CH2", "V_3": "CH3"}


def write_layout(
    capture: Any, path: str | os.PathLike, fmt: str | None, uniform_rtol: float
) -> Path:
    """Write ``capture`` (a :class:`~precise_impact.lab.capture.Capture`) in one of
    :data:`WRITE_FORMATS` (``None``: by suffix); printed times must stay uniform to
    ``uniform_rtol`` (the readers' check)."""
    check_type(path, (str, os.PathLike), "path", "a file path (str or os.PathLike)")
    path = Path(path)
    fmt = fmt or {".npz": "npz", ".bin": "keysight-bin"}.get(path.suffix.lower(), "csv")
    if fmt not in WRITE_FORMATS:
        raise ParameterError("format", fmt, "one of " + ", ".join(WRITE_FORMATS))
    ch = capture.channels
    labels = [_LABELS[k] for k in ch]
    cols = [capture.channels[k] for k in ch]
    t, dt = capture.t, capture.sample_interval
    if fmt == "npz":
        return capture.write_npz(path)
    if fmt == "keysight-bin":
        _check_printable(capture, fmt, path, uniform_rtol)
        return _write_ag10(path, capture, labels, cols)
    if fmt == "tek-tbs":
        _check_printable(capture, fmt, path, uniform_rtol)
        path.mkdir(parents=True, exist_ok=True)
        for lab, y in zip(labels, cols, strict=True):
            _write_text(path / f"F0000{lab}.CSV", _tbs_text(t, y, dt, lab))
        return path
    _check_printable(capture, fmt, path, uniform_rtol)
    out = io.StringIO()
    _TEXT_WRITERS[fmt](out, t, dt, np.column_stack(cols), list(ch), labels)
    _write_text(path, out.getvalue())
    return path


def _text_csv(
    out: Any, t: np.ndarray, dt: float, vals: np.ndarray, ch: list[str], labels: list[str]
) -> None:
    """The project's generic CSV (every bit: %.17g)."""
    # the project's own layout keeps every bit: %.17g round-trips any float64
    out.write("time [s]," + ",".join(f"{k} [V]" for k in ch) + "\n")
    np.savetxt(out, np.column_stack([t, vals]), delimiter=",", fmt=["%.17g"] + ["%.17g"] * len(ch))


def _text_rigol(
    out: Any, t: np.ndarray, dt: float, vals: np.ndarray, ch: list[str], labels: list[str]
) -> None:
    """Rigol DS1000Z CSV: index rows, start and increment in the header."""
    n = len(t)
    out.write("X," + ",".join(labels) + ",Start,Increment,\n")
    out.write("Sequence," + ",".join(["Volt"] * len(ch)) + f",{t[0]:.6e},{dt:.6e}\n")
    np.savetxt(
        out,
        np.column_stack([np.arange(n), vals]),
        delimiter=",",
        fmt=["%d"] + ["%.5e"] * len(ch),
        newline=",\n",
    )


def _text_keysight(
    out: Any, t: np.ndarray, dt: float, vals: np.ndarray, ch: list[str], labels: list[str]
) -> None:
    """Keysight InfiniiVision CSV: ``x-axis`` and ``second`` header rows."""
    out.write("x-axis," + ",".join(lab[2:] for lab in labels) + "\n")
    out.write("second," + ",".join(["Volt"] * len(ch)) + "\n")
    np.savetxt(out, np.column_stack([t, vals]), delimiter=",", fmt=["%.9e"] + ["%.6e"] * len(ch))


def _text_tek(
    out: Any, t: np.ndarray, dt: float, vals: np.ndarray, ch: list[str], labels: list[str]
) -> None:
    """Tektronix MDO/MSO CSV: the key-value preamble, then ``TIME,CH1,..``."""
    n = len(t)
    k = len(ch)
    pre = [
        ("Model", ["MDO3024"]),
        ("Firmware Version", ["1.30"]),
        ("", []),
        ("Waveform Type", ["ANALOG"]),
        ("Point Format", ["Y"]),
        ("Horizontal Units", ["s"]),
        ("Horizontal Scale", [f"{n * dt / 10:.6g}"]),
        ("Horizontal Delay", ["0"]),
        ("Sample Interval", [f"{dt:.6g}"]),
        ("Record Length", [str(n)]),
        ("Gating", ["0.0% to 100.0%"]),
        ("Probe Attenuation", ["1"] * k),
        ("Vertical Units", ["V"] * k),
        ("Vertical Offset", ["0"] * k),
        ("Vertical Scale", ["1"] * k),
        ("Vertical Position", ["0"] * k),
        ("", []),
        ("", []),
        ("", []),
        ("Label", [""] * k),
    ]
    for key, v in pre:
        out.write(",".join([key, *v]) + "\n")
    out.write("TIME," + ",".join(labels) + "\n")
    np.savetxt(out, np.column_stack([t, vals]), delimiter=",", fmt=["%.7e"] + ["%.5g"] * len(ch))


def _text_siglent(
    out: Any, t: np.ndarray, dt: float, vals: np.ndarray, ch: list[str], labels: list[str]
) -> None:
    """Siglent SDS CSV: the key-value header, then ``Second,Volt,..``."""
    n = len(t)
    out.write(f"Record Length,Analog:{n}\n")
    out.write(f"Sample Interval,{dt:.6E}\n")
    out.write("Vertical Units," + ",".join(f"{lab}:V" for lab in labels) + "\n")
    out.write("Vertical Scale," + ",".join(f"{lab}:1.00E+00" for lab in labels) + "\n")
    out.write("Vertical Offset," + ",".join(f"{lab}:0.00E+00" for lab in labels) + "\n")
    out.write("Horizontal Units,S\n")
    out.write(f"Horizontal Scale,{n * dt / 14:.6E}\n")
    out.write("Model Number,SDS1104X-E\n")
    out.write("Source," + ",".join(labels) + "\n")
    out.write("Second," + ",".join(["Volt"] * len(ch)) + "\n")
    np.savetxt(out, np.column_stack([t, vals]), delimiter=",", fmt=["%.8E"] + ["%.5E"] * len(ch))


_TEXT_WRITERS = {
    "csv": _text_csv,
    "rigol": _text_rigol,
    "keysight": _text_keysight,
    "tek": _text_tek,
    "siglent": _text_siglent,
}


#: What each layout prints: the time column's format (``None``: start and increment in the
#: header, ``'f8'`` binary float64) and the voltage columns' (``'f4'``: binary float32), as the
#: instruments write them.
_PRINTED = {
    "csv": ("%.17g", "%.17g"),
    "rigol": (None, "%.5e"),
    "keysight": ("%.9e", "%.6e"),
    "tek": ("%.7e", "%.5g"),
    "siglent": ("%.8E", "%.5E"),
    "tek-tbs": ("%.10e", "%.5e"),
    "keysight-bin": ("f8", "f4"),
}
#: Largest rounding of a printed voltage, relative to its channel's peak-to-peak (a 10-bit
#: code: finer than any scorer's use of the channel, coarser than every layout's digits on a
#: signal within its full scale).
PRINT_MAX_ROUNDING = 1e-3


def _printed(y: np.ndarray, how: str) -> np.ndarray:
    if how == "f4":
        return np.asarray(y, "<f4").astype(float)
    if how == "f8":
        return np.asarray(y, float)
    return np.char.mod(how, np.asarray(y, float)).astype(float)


def _check_printable(capture: Any, fmt: str, path: Path, uniform_rtol: float) -> None:
    """Refuse, before writing, a capture that ``fmt``'s printed digits cannot carry: the times
    as printed must still be uniform to ``uniform_rtol``
    (:data:`~precise_impact.lab.capture.UNIFORM_RTOL`, what the reader checks), each channel's
    rounding within :data:`PRINT_MAX_ROUNDING` of its peak-to-peak (a large offset on a small
    signal loses the signal)."""

    t_fmt, v_fmt = _PRINTED[fmt]
    t, dt = capture.t, capture.sample_interval
    if t_fmt is not None:
        steps = np.diff(_printed(t, t_fmt))
        med = float(np.median(steps))
        if not (med > 0 and float(np.max(np.abs(steps - med))) <= uniform_rtol * med):
            raise ParameterError(
                "format",
                fmt,
                f"a layout whose {t_fmt} times resolve the sample step {dt:.3g} s at "
                f"t = {float(np.max(np.abs(t))):.3g} s ({path.name}): write csv or npz, or a "
                "smaller trigger offset",
            )
    else:
        t0, dtp = _printed(np.array([t[0], dt]), "%.6e")
        if abs(t0 - t[0]) > uniform_rtol * dt or abs(dtp - dt) > 0.1 * uniform_rtol * dt:
            raise ParameterError(
                "format",
                fmt,
                f"a layout whose header (%.6e) resolves the start {t[0]:.6g} s to a sample "
                f"step {dt:.3g} s: write csv or npz",
            )
    for k, y in capture.channels.items():
        pp = float(np.max(y) - np.min(y))
        err = float(np.max(np.abs(_printed(y, v_fmt) - y)))
        if err > PRINT_MAX_ROUNDING * pp:
            raise ParameterError(
                "format",
                fmt,
                f"a layout whose {v_fmt} volts keep {k} (peak-to-peak {pp:.3g} V around "
                f"{float(np.mean(y)):.3g} V): it rounds by {err:.3g} V; write csv or npz",
            )


def _write_text(path: Path, text: str) -> None:
    atomic_write(path, lambda fh: fh.write(text), binary=False)


def _tbs_text(t: np.ndarray, y: np.ndarray, dt: float, label: str) -> str:
    head = [
        ("Record Length", f"{len(t):.6e}"),
        ("Sample Interval", f"{dt:.6e}"),
        ("Trigger Point", f"{max(0.0, -t[0] / dt):.12e}"),
        ("", ""),
        ("", ""),
        ("", ""),
        ("Source", label),
        ("Vertical Units", "V"),
        ("Vertical Scale", "1.000000e+00"),
        ("Vertical Offset", "0.000000e+00"),
        ("Horizontal Units", "s"),
        ("Horizontal Scale", f"{len(t) * dt / 10:.6e}"),
        ("Pt Fmt", "Y"),
        ("Yzero", "0.000000e+00"),
        ("Probe Atten", "1.000000e+00"),
        ("Model Number", "TBS1052B"),
        ("Serial Number", "C000000"),
        ("Firmware Version", "FV:v4.00"),
    ]
    lines = []
    for i in range(len(t)):
        k, v = head[i] if i < len(head) else ("", "")
        lines.append(f"{k},{v},,{t[i]:.10e},{y[i]:.5e},")
    return "\n".join(lines) + "\n"


def _write_ag10(path: Path, capture: Any, labels: list[str], cols: list[np.ndarray]) -> Path:
    """Keysight/Agilent ``AG10`` ``.bin``: file header, then per channel a 140-byte waveform
    header and one float32 buffer (the layout of RigolWFM's ``agilent_agxx_bin`` schema)."""
    t, dt = capture.t, capture.sample_interval
    body = b""
    for lab, y in zip(labels, cols, strict=True):
        yy = np.asarray(y, "<f4")
        n = yy.size
        hdr = struct.pack(
            "<IIIIIfdddII16s16s24s16sdI",
            140,  # header size
            1,  # waveform type: normal
            1,  # buffers
            n,
            1,  # count
            n * dt,  # x display range
            float(t[0]),  # x display origin
            dt,  # x increment
            float(t[0]),  # x origin
            2,  # x units: s
            1,  # y units: V
            b"26 NOV 2026",
            b"04:00:00",
            b"DSO-X 2024A:MY00000000",
            lab[2:].encode(),
            0.0,
            0,
        )
        body += hdr + struct.pack("<IHHI", 12, 1, 4, 4 * n) + yy.tobytes()
    blob = b"AG10" + struct.pack("<II", 12 + len(body), len(labels)) + body
    atomic_write(path, lambda fh: fh.write(blob), binary=True)
    return path
