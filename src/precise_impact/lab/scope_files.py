"""Oscilloscope capture files: readers (and writers of the same layouts, for tests and synthesis).

:func:`read_capture` returns a :class:`~precise_impact.lab.capture.Capture` in SI units from the
files bench oscilloscopes write (:data:`READ_FORMATS`; :func:`write_capture` writes
:data:`WRITE_FORMATS`); the layout is sniffed from the first lines (or given as ``fmt``).  Every
refusal is one :class:`~precise_impact.errors.ParameterError` naming the file (or ``channels``)
and what is wrong; the CLI prints it as one line and exits 2.  Each layout as the instruments
write it (and its public source), the time grid and the channel mapping:
:doc:`/guide/captures`, "Capture files in detail".
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.errors import OptionalDependencyError, ParameterError, check_type
from precise_impact.lab.capture import CHANNELS, UNIFORM_RTOL, Capture
from precise_impact.lab.scope_writers import WRITE_FORMATS, write_layout

__all__ = [
    "read_capture",
    "write_capture",
    "parse_channels",
    "READ_FORMATS",
    "WRITE_FORMATS",
    "BINARY_SUFFIXES",
]

READ_FORMATS = (
    "auto",
    "csv",
    "npz",
    "rigol",
    "rigol-mso5000",
    "keysight",
    "tek-tbs",
    "tek",
    "siglent",
    "binary",
)
#: What a capture-file argument may be.
FILE_ARG = "a file path (str or os.PathLike) or a list of them (one per channel)"
BINARY_SUFFIXES = (".wfm", ".bin", ".isf", ".trc", ".wvf")

#: Time units a file may state, to seconds.
_TIME_UNITS = {
    "s": 1.0,
    "sec": 1.0,
    "second": 1.0,
    "seconds": 1.0,
    "ms": 1e-3,
    "us": 1e-6,
    "\u00b5s": 1e-6,
    "\u03bcs": 1e-6,
    "ns": 1e-9,
}
#: Voltage units a file may state, to volts.
_VOLT_UNITS = {
    "v": 1.0,
    "volt": 1.0,
    "volts": 1.0,
    "mv": 1e-3,
    "uv": 1e-6,
    "\u00b5v": 1e-6,
    "kv": 1e3,
}


# =============================================================================== helpers
def _bad(path: Any, what: str, allowed: str) -> ParameterError:
    """The one-line refusal: the file's name (not its whole path: the value is cut at 80
    characters) and what is wrong with it."""
    return ParameterError("file", f"{Path(str(path)).name}: {what}", allowed)


def _unit(path: Any, unit: str, kind: str, column: str) -> float:
    """The factor to SI of a ``kind`` ('time' or 'volt') unit, or the wrong-unit refusal."""
    u = unit.strip().strip("[]()").strip().lower()
    table = _TIME_UNITS if kind == "time" else _VOLT_UNITS
    if u in table:
        return table[u]
    want = "s, ms, us, ns" if kind == "time" else "V, mV, uV"
    return _raise(_bad(path, f"{column} in '{unit}'", f"a {kind} axis in {want} (wrong unit)"))


def _exists(p: Path) -> bool:
    """Whether ``p`` exists; a name the system cannot even look up (too long) does not."""
    try:
        return p.exists()
    except OSError:
        return False


def _raise(e: Exception) -> Any:
    raise e


def _float(path: Any, text: str, line: int, column: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise _bad(
            path, f"line {line}: {column} = {text.strip()[:20]!r}", "numbers (a damaged file?)"
        ) from None


def _rows_numeric(path: Any, rows: list[list[str]], first_line: int, cols: Sequence[int]) -> Any:
    """The columns ``cols`` of ``rows`` as a float array; one line naming the first bad cell."""
    out = np.empty((len(rows), len(cols)))
    for i, r in enumerate(rows):
        if len(r) <= max(cols):
            raise _bad(
                path,
                f"line {first_line + i}: {len(r)} fields",
                f"{max(cols) + 1} fields per row (a truncated or damaged file?)",
            )
        for j, c in enumerate(cols):
            try:
                out[i, j] = float(r[c])
            except ValueError:
                raise _bad(
                    path,
                    f"line {first_line + i}: {r[c].strip()[:20]!r}",
                    "numbers (a damaged file?)",
                ) from None
    return out


def parse_channels(channels: Any, available: Sequence[str], path: Any = "") -> dict[str, str]:
    """``{'V_s': file channel, 'V_q': ..., ['V_3': ...]}`` from ``channels``.

    ``None``: the file's channels in order (two or three; more need a choice); ``'CH2,CH1'`` or
    a sequence: in role order; ``'V_s=CH2,V_q=CH1'`` or a dict: by role.  Names compare without
    case, spaces or underscores (``'ch 1'`` is ``CH1``).
    """
    norm = {_key(a): a for a in available}
    if channels is None:
        return _channels_in_order(available, path)
    mapping, channels = _role_mapping(channels)
    bad_roles = sorted(set(mapping) - set(CHANNELS))
    if bad_roles or not {"V_s", "V_q"} <= set(mapping):
        raise ParameterError(
            "channels", channels, "roles V_s and V_q (and optionally V_3), e.g. V_s=CH1,V_q=CH2"
        )
    out = {}
    for role, name in mapping.items():
        if _key(name) not in norm:
            raise ParameterError(
                "channels",
                f"{role}={name}",
                f"a channel of {Path(str(path)).name or 'the file'}: {', '.join(available)}"
                " (wrong channel)",
            )
        out[role] = norm[_key(name)]
    if len(set(out.values())) != len(out):
        raise ParameterError("channels", channels, "a different file channel for each role")
    return out


def _channels_in_order(available: Sequence[str], path: Any) -> dict[str, str]:
    """The file's two or three channels as ``V_s``, ``V_q``[, ``V_3``], in file order."""
    if len(available) < 2:
        raise _bad(path, f"{len(available)} channel(s)", "two or three channels: V_s, V_q[, V_3]")
    if len(available) > 3:
        raise ParameterError(
            "channels",
            None,
            f"a choice among the file's {len(available)} channels ({', '.join(available)}): "
            "e.g. --channels V_s=CH1,V_q=CH2,V_3=CH3",
        )
    return dict(zip(CHANNELS, available, strict=False))


def _role_mapping(channels: Any) -> tuple[dict[str, str], Any]:
    """``({role: name}, channels as parsed)`` from a string, a sequence or a dict of names."""
    if isinstance(channels, str):
        parts = [p.strip() for p in channels.split(",") if p.strip()]
        if all("=" in p for p in parts):
            channels = dict(p.split("=", 1) for p in parts)
        elif any("=" in p for p in parts):
            raise ParameterError("channels", channels, "either all 'role=name' or all names")
        else:
            channels = parts
    if isinstance(channels, dict):
        mapping = {k.strip(): str(v).strip() for k, v in channels.items()}
    else:
        mapping = dict(zip(CHANNELS, [str(c) for c in channels], strict=False))
        if len(channels) > 3:
            raise ParameterError("channels", list(channels), "two or three names: V_s, V_q[, V_3]")
    return mapping, channels


def _key(name: str) -> str:
    return re.sub(r"[\s_]", "", str(name)).lower()


def _finish(
    path: Any,
    t: np.ndarray,
    data: dict[str, np.ndarray],
    channels: Any,
    source: dict,
    dt: float | None = None,
    n_expected: int | None = None,
) -> Capture:
    if n_expected is not None and len(t) < n_expected:
        raise _bad(
            path,
            f"{len(t)} samples, header says {n_expected}",
            "as many samples as the header's record length (a truncated file?)",
        )
    t = _time_grid(np.asarray(t, float))
    roles = parse_channels(channels, list(data), path)
    src = dict(source, path=str(path), channel_map=roles, file_channels=list(data))
    return Capture.make(
        t,
        data[roles["V_s"]],
        data[roles["V_q"]],
        data[roles["V_3"]] if "V_3" in roles else None,
        sample_interval=dt,
        source=src,
        what=str(path),
    )


def _time_grid(t: np.ndarray) -> np.ndarray:
    """The printed time axis replaced by its least-squares uniform grid when every printed time
    lies within a quarter sample of it (instruments print times to 4-7 significant digits: a
    long record's steps then differ by more than the uniformity test allows).  A missing or
    repeated sample moves the printed times half a sample or more off any grid: left as is,
    for :meth:`Capture.make` to refuse."""
    n = len(t)
    if n < 3 or not np.all(np.isfinite(t)):
        return t
    k = np.arange(n, dtype=float)
    slope, icpt = np.polyfit(k, t, 1)
    if not slope > 0:
        return t
    grid = icpt + slope * k
    return grid if float(np.max(np.abs(t - grid))) < 0.25 * slope else t


def _read_lines(path: Path) -> list[list[str]]:
    try:
        text = path.read_text(encoding="utf-8-sig", errors="strict")
    except UnicodeDecodeError:
        raise _bad(path, "not UTF-8 text", "a CSV text file (a binary or damaged file?)") from None
    except OSError as e:
        raise ParameterError("file", str(path), f"a readable file ({e.strerror})") from None
    if not text.strip():
        raise _bad(path, "empty", "a capture file with samples")
    if not text.endswith(("\n", "\r")):
        # every instrument ends its last row with a newline: a file cut mid-write does not
        last = text.rsplit("\n", 1)[-1]
        raise _bad(path, f"last line {last[:30]!r} has no end", "complete rows (a truncated file?)")
    return [r for r in csv.reader(io.StringIO(text))]


# =============================================================================== sniffing
def sniff_format(path: Path) -> str:
    """The layout of ``path`` (one of :data:`READ_FORMATS` but ``'auto'``)."""
    if path.is_dir():
        return "tek-tbs" if _tbs_files(path) else "binary"
    suf = path.suffix.lower()
    if suf == ".npz":
        return "npz"
    if suf in BINARY_SUFFIXES:
        return "binary"
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError as e:
        raise ParameterError("file", str(path), f"a readable file ({e.strerror})") from None
    if head[:2] == b"PK":
        return "npz"
    try:
        text = head.decode("utf-8-sig")
    except UnicodeDecodeError:
        return "binary"
    return _text_layout(text.splitlines())


def _text_layout(lines: list[str]) -> str:
    """The layout of a text file from its first lines (the vendors' header signatures)."""
    first = lines[0].strip().lower() if lines else ""
    if first.startswith("x,") and "increment" in first:
        return "rigol"
    if first.startswith("time(s)"):
        return "rigol-mso5000"
    if first.startswith("x-axis"):
        return "keysight"
    if first.startswith("record length") and first.count(",") >= 4:
        return "tek-tbs"
    if first.startswith("record length") or any(ln.lower().startswith("second,") for ln in lines):
        return "siglent"
    if first.startswith("model,") or any(ln.upper().startswith("TIME,") for ln in lines[:40]):
        return "tek"
    return "csv"


# =============================================================================== readers
def read_capture(
    path: str | os.PathLike | Sequence[str | os.PathLike],
    channels: Any = None,
    fmt: str = "auto",
) -> Capture:
    """Read an oscilloscope capture.

    Parameters
    ----------
    path : path, directory or list of paths
        One file (any layout of the module docstring), a Tektronix ``ALLnnnn`` directory (one
        CSV per channel), or one file per channel (``.isf``, TBS CSVs).
    channels : str, sequence, dict or None
        The file's channels for ``V_s``, ``V_q`` (and ``V_3``): :func:`parse_channels`.
    fmt : str, default ``'auto'``
        One of :data:`READ_FORMATS` (``'auto'`` sniffs the first lines).

    Returns
    -------
    Capture
        In seconds and volts, ``source`` naming the format, instrument, header fields and the
        channel mapping.

    Raises
    ------
    ParameterError
        One line naming the file and the problem (damaged, truncated, wrong unit) or
        ``channels`` (wrong channel).
    OptionalDependencyError
        A binary file without RigolWFM installed.

    See Also
    --------
    write_capture : the same layouts, written.
    precise_impact.lab.attractor.score_capture : score what was read.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from precise_impact import read_capture, synth_capture, write_capture
    >>> f = write_capture(synth_capture(periods=5, transient=5),
    ...                   pathlib.Path(tempfile.mkdtemp()) / "tek.csv", "tek")
    >>> cap = read_capture(f, "V_s=CH1,V_q=CH2")
    >>> cap.source["format"], cap.units["V_s"]
    ('tek', 'V')
    """
    if fmt not in READ_FORMATS:
        raise ParameterError("format", fmt, "one of " + ", ".join(READ_FORMATS))
    if not isinstance(path, (str, os.PathLike)):
        check_type(path, (list, tuple), "path", FILE_ARG)
        paths = [Path(check_type(p, (str, os.PathLike), "path", FILE_ARG)) for p in path]
        if not paths:
            raise ParameterError("file", [], "at least one file")
        for p in paths:
            if not _exists(p):
                raise ParameterError("file", str(p), "an existing file")
        if len(paths) == 1:
            return read_capture(paths[0], channels, fmt)
        kind = sniff_format(paths[0]) if fmt == "auto" else fmt
        if kind == "tek-tbs":
            return _read_tbs(paths, channels)
        return _read_binary(paths, channels)
    p = Path(path)
    if not _exists(p):
        raise ParameterError("file", str(p), "an existing file or directory")
    kind = sniff_format(p) if fmt == "auto" else fmt
    if p.is_dir():
        if kind == "tek-tbs":
            return _read_tbs(_tbs_files(p), channels)
        files = sorted(q for q in p.iterdir() if q.suffix.lower() in BINARY_SUFFIXES)
        if not files:
            raise _bad(
                p, "no capture files", "a directory of FnnnnCHk.CSV or binary waveform files"
            )
        return _read_binary(files, channels)
    reader = {
        "csv": _read_generic,
        "npz": _read_npz,
        "rigol": _read_rigol,
        "rigol-mso5000": _read_rigol_mso5000,
        "keysight": _read_keysight,
        "tek": _read_tek,
        "siglent": _read_siglent,
    }.get(kind)
    if kind == "tek-tbs":
        return _read_tbs(_tbs_siblings(p), channels)
    if kind == "binary":
        return _read_binary([p], channels)
    assert reader is not None
    return reader(p, channels)


def _read_npz(path: Path, channels: Any) -> Capture:
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: np.asarray(z[k]) for k in z.files}
    except Exception as e:  # zipfile.BadZipFile, ValueError, EOFError ...
        raise _bad(path, f"not a readable NPZ ({type(e).__name__})", "an NPZ archive") from None
    meta: dict = {}
    if "meta" in arrays:
        try:
            meta = json.loads(str(arrays.pop("meta")))
        except ValueError:
            raise _bad(path, "meta is not JSON", "the meta of Capture.write_npz") from None
    tkey = next((k for k in ("t", "time", "Time") if k in arrays), None)
    if tkey is None:
        raise _bad(path, f"arrays {sorted(arrays)}", "a time array 't' (seconds)")
    t = arrays.pop(tkey).astype(float)
    units = meta.get("units", {})
    if units.get("t", "s") != "s":
        raise _bad(path, f"t in {units['t']!r}", "a time axis in s (wrong unit)")
    data = {}
    for k, v in arrays.items():
        if v.ndim == 1 and v.dtype.kind in "fiu":
            if units.get(k, "V") != "V":
                raise _bad(path, f"{k} in {units[k]!r}", "channels in V (wrong unit)")
            data[k] = v.astype(float)
    if len(data[next(iter(data))]) != len(t) if data else False:
        pass
    src = {k: v for k, v in meta.get("source", {}).items() if k not in ("path", "channel_map")}
    src.setdefault("format", "npz")
    if channels is None and {"V_s", "V_q"} <= set(data):
        channels = {c: c for c in CHANNELS if c in data}
    return _finish(path, t, data, channels, src, dt=meta.get("sample_interval"))


def _read_generic(path: Path, channels: Any) -> Capture:
    rows = [r for r in _read_lines(path) if any(c.strip() for c in r)]
    header: list[str] | None = None
    try:
        float(rows[0][0])
    except ValueError:
        header = [c.strip() for c in rows[0]]
        rows = rows[1:]
    if not rows:
        raise _bad(path, "no data rows", "a capture with samples")
    ncol = len(rows[0])
    while ncol and not rows[0][ncol - 1].strip():
        ncol -= 1  # a trailing comma
    if ncol < 3:
        raise _bad(path, f"{ncol} column(s)", "time and two or three channels")
    a = _rows_numeric(path, rows, 2 if header else 1, list(range(ncol)))
    tscale, names, vscale = 1.0, [f"CH{i}" for i in range(1, ncol)], [1.0] * (ncol - 1)
    if header:
        tname, tunit = _name_unit(header[0])
        if tunit:
            tscale = _unit(path, tunit, "time", tname or "time")
        names = []
        for i, h in enumerate(header[1:ncol]):
            nm, un = _name_unit(h)
            names.append(nm or f"CH{i + 1}")
            if un:
                vscale[i] = _unit(path, un, "volt", nm)
    data = {n: a[:, i + 1] * vscale[i] for i, n in enumerate(names)}
    return _finish(
        path, a[:, 0] * tscale, data, channels, {"format": "csv", "instrument": "generic"}
    )


def _name_unit(h: str) -> tuple[str, str]:
    m = re.match(r"^\s*(.*?)\s*[\[(]\s*([^\])]*)\s*[\])]\s*$", h)
    if m:
        return m.group(1), m.group(2)
    return h.strip(), ""


def _read_rigol(path: Path, channels: Any) -> Capture:
    rows = _read_lines(path)
    if len(rows) < 3:
        raise _bad(path, f"{len(rows)} lines", "a Rigol CSV header and samples (truncated?)")
    h0, h1 = [c.strip() for c in rows[0]], [c.strip() for c in rows[1]]
    try:
        i_start = [c.lower() for c in h0].index("start")
        i_inc = [c.lower() for c in h0].index("increment")
    except ValueError:
        raise _bad(path, "no Start/Increment columns", "the Rigol DS1000Z CSV header") from None
    names = [c for c in h0[1:i_start] if c]
    if len(h1) <= i_inc:
        raise _bad(path, "line 2 cut short", "Sequence,<units>,<start>,<increment> (truncated?)")
    for i, n in enumerate(names):
        _unit(path, h1[1 + i], "volt", n)  # Rigol writes 'Volt'; an 'Ampere' probe is refused
    start = _float(path, h1[i_start], 2, "Start")
    inc = _float(path, h1[i_inc], 2, "Increment")
    if not inc > 0:
        raise _bad(path, f"Increment = {inc}", "a positive sample interval")
    a = _rows_numeric(path, rows[2:], 3, list(range(len(names) + 1)))
    scale = [_unit(path, h1[1 + i], "volt", n) for i, n in enumerate(names)]
    data = {n: a[:, i + 1] * scale[i] for i, n in enumerate(names)}
    t = _rigol_time(path, h1[0], a[:, 0], start, inc)
    src = {"format": "rigol", "instrument": "Rigol DS1000Z", "start": start, "increment": inc}
    return _finish(path, t, data, channels, dict(src, x_unit=h1[0]), dt=inc)


def _rigol_time(path: Path, unit: str, x: np.ndarray, start: float, inc: float) -> np.ndarray:
    """The sample times of a Rigol CSV's X column, read by the unit its second header row states:
    ``Sequence`` a sample index (``start + x * increment``), a time unit (``Second``, ``s``,
    ``ms``, ...: some DS1000Z firmwares) the times themselves, which must start at the header's
    ``Start`` (to a sample and Start's 7 printed digits; their step is checked against
    ``Increment`` by :meth:`Capture.make`)."""
    if unit.lower() == "sequence":
        return start + x * inc
    t = x * _unit(path, unit, "time", "X")
    if len(t) and not abs(t[0] - start) <= inc + 1e-6 * abs(start):
        raise _bad(
            path,
            f"X from {t[0]:.6g} s, Start {start:.6g} s",
            f"an X column in {unit!r} that starts at the header's Start (a damaged file?)",
        )
    return t


def _read_rigol_mso5000(path: Path, channels: Any) -> Capture:
    rows = _read_lines(path)
    h0 = [c.strip() for c in rows[0]]
    names, scale = [], []
    for c in h0[1:]:
        m = re.match(r"^(CH\d|D\d+|MATH\d?|REF\d?)\s*\(?(\w*)\)?$", c, re.I)
        if not c or "=" in c:
            continue
        if not m:
            raise _bad(path, f"column {c!r}", "Rigol columns CHkV (a damaged header?)")
        names.append(m.group(1).upper())
        scale.append(_unit(path, m.group(2) or "V", "volt", m.group(1)))
    tname, tunit = _name_unit(h0[0])
    tscale = _unit(path, tunit or "s", "time", tname)
    a = _rows_numeric(path, rows[1:], 2, list(range(len(names) + 1)))
    data = {n: a[:, i + 1] * scale[i] for i, n in enumerate(names)}
    src = {"format": "rigol-mso5000", "instrument": "Rigol MSO5000"}
    return _finish(path, a[:, 0] * tscale, data, channels, src)


def _read_keysight(path: Path, channels: Any) -> Capture:
    rows = _read_lines(path)
    if len(rows) < 3:
        raise _bad(path, f"{len(rows)} lines", "x-axis,... / second,Volt,... header and samples")
    h0 = [c.strip() for c in rows[0] if c.strip()]
    h1 = [c.strip() for c in rows[1] if c.strip()]
    if len(h1) != len(h0):
        raise _bad(path, "header lines of different widths", "x-axis,1,2 / second,Volt,Volt")
    tscale = _unit(path, h1[0], "time", "x-axis")
    names = [n if n.upper().startswith(("CH", "MATH", "REF")) else f"CH{n}" for n in h0[1:]]
    scale = [_unit(path, u, "volt", n) for n, u in zip(names, h1[1:], strict=True)]
    a = _rows_numeric(path, rows[2:], 3, list(range(len(names) + 1)))
    data = {n: a[:, i + 1] * scale[i] for i, n in enumerate(names)}
    src = {"format": "keysight", "instrument": "Keysight InfiniiVision"}
    return _finish(path, a[:, 0] * tscale, data, channels, src)


def _kv_header(rows: list[list[str]], stop: Any) -> tuple[dict[str, list[str]], int]:
    """``{key: values}`` of the ``key,value...`` preamble rows, and the index of the row that
    ``stop(row)`` accepts (the column-name row)."""
    head: dict[str, list[str]] = {}
    for i, r in enumerate(rows):
        if r and stop(r):
            return head, i
        if r and r[0].strip():
            head[r[0].strip().lower()] = [c.strip() for c in r[1:]]
    return head, len(rows)


def _read_tek(path: Path, channels: Any) -> Capture:
    rows = _read_lines(path)
    head, k = _kv_header(rows, lambda r: r[0].strip().upper() == "TIME")
    if k >= len(rows) - 1:
        raise _bad(path, "no TIME,CH1,... row or no samples", "the Tektronix CSV layout")
    names = [c.strip().upper().replace(" ", "") for c in rows[k][1:] if c.strip()]
    hu = (head.get("horizontal units") or ["s"])[0]
    tscale = _unit(path, hu, "time", "Horizontal Units")
    vu = [u for u in head.get("vertical units", []) if u] or ["V"] * len(names)
    if len(vu) < len(names):
        vu = vu + [vu[-1]] * (len(names) - len(vu))
    scale = [_unit(path, u, "volt", n) for n, u in zip(names, vu, strict=False)]
    a = _rows_numeric(path, rows[k + 1 :], k + 2, list(range(len(names) + 1)))
    data = {n: a[:, i + 1] * scale[i] for i, n in enumerate(names)}
    n_exp = _int_field(head, "record length")
    dt = _float_field(head, "sample interval")
    model = (head.get("model") or ["Tektronix"])[0]
    src = {"format": "tek", "instrument": f"Tektronix {model}".strip()}
    return _finish(
        path, a[:, 0] * tscale, data, channels, src, dt=dt and dt * tscale, n_expected=n_exp
    )


def _int_field(head: dict, key: str) -> int | None:
    v = head.get(key)
    if not v or not v[0]:
        return None
    try:
        return int(float(v[0].split(":")[-1]))
    except ValueError:
        return None


def _float_field(head: dict, key: str) -> float | None:
    v = head.get(key)
    if not v or not v[0]:
        return None
    try:
        return float(v[0].split(":")[-1])
    except ValueError:
        return None


def _read_siglent(path: Path, channels: Any) -> Capture:
    rows = _read_lines(path)
    head, k = _kv_header(rows, lambda r: r[0].strip().lower() in ("second", "time", "time(s)"))
    if k >= len(rows) - 1:
        raise _bad(path, "no Second,Volt row or no samples", "the Siglent CSV layout")
    units = [c.strip() for c in rows[k] if c.strip()]
    tscale = _unit(path, units[0], "time", "Second")
    names = [c.strip().upper() for c in head.get("source", []) if c.strip()]
    if not names:
        names = [c.split(":")[0].strip().upper() for c in head.get("vertical scale", []) if c]
    if len(names) != len(units) - 1:
        names = [f"CH{i}" for i in range(1, len(units))]
    scale = [_unit(path, u, "volt", n) for n, u in zip(names, units[1:], strict=True)]
    a = _rows_numeric(path, rows[k + 1 :], k + 2, list(range(len(names) + 1)))
    data = {n: a[:, i + 1] * scale[i] for i, n in enumerate(names)}
    dt = _float_field(head, "sample interval")
    sr = _float_field(head, "sample rate")
    if dt is None and sr:
        dt = 1.0 / sr
    model = (head.get("model number") or ["SDS"])[0]
    src = {"format": "siglent", "instrument": f"Siglent {model}"}
    return _finish(
        path,
        a[:, 0] * tscale,
        data,
        channels,
        src,
        dt=dt,
        n_expected=_int_field(head, "record length"),
    )


def _tbs_files(d: Path) -> list[Path]:
    return sorted(q for q in d.iterdir() if re.match(r"^F\d{4}CH\d\.CSV$", q.name, re.I))


def _tbs_siblings(p: Path) -> list[Path]:
    m = re.match(r"^(F\d{4})CH\d\.CSV$", p.name, re.I)
    if not m:
        return [p]
    return sorted(
        q for q in p.parent.iterdir() if re.match(rf"^{m.group(1)}CH\d\.CSV$", q.name, re.I)
    )


def _read_tbs(paths: list[Path], channels: Any) -> Capture:
    if not paths:
        raise ParameterError("file", "", "FnnnnCHk.CSV files")
    data: dict[str, np.ndarray] = {}
    t_ref: np.ndarray | None = None
    dt_ref = None
    model = "TBS"
    for p in paths:
        rows = _read_lines(p)
        head = {r[0].strip().lower(): r[1].strip() for r in rows if len(r) > 1 and r[0].strip()}
        if "record length" not in head or "sample interval" not in head:
            raise _bad(p, "no Record Length / Sample Interval", "the Tektronix TBS CSV layout")
        n = int(_float(p, head["record length"], 1, "Record Length"))
        dt = _float(p, head["sample interval"], 2, "Sample Interval")
        tscale = _unit(p, head.get("horizontal units", "s"), "time", "Horizontal Units")
        name = head.get("source", p.stem[-3:]).upper().replace(" ", "")
        vscale = _unit(p, head.get("vertical units", "V"), "volt", name)
        a = _rows_numeric(p, rows, 1, [3, 4])
        if len(a) < n:
            raise _bad(
                p, f"{len(a)} samples, header says {n}", "the full record (a truncated file?)"
            )
        t = a[:, 0] * tscale
        if t_ref is not None and (len(t) != len(t_ref) or np.max(np.abs(t - t_ref)) > 0.5 * dt):
            raise _bad(p, "a time axis unlike the other channels'", "files of one acquisition")
        if name in data:
            raise _bad(p, f"channel {name} twice", "one file per channel")
        t_ref, dt_ref = t, dt * tscale
        data[name] = a[:, 1] * vscale
        model = head.get("model number", model)
    assert t_ref is not None
    src = {
        "format": "tek-tbs",
        "instrument": f"Tektronix {model}",
        "files": [str(p) for p in paths],
    }
    return _finish(
        paths[0].parent if len(paths) > 1 else paths[0], t_ref, data, channels, src, dt=dt_ref
    )


def _isf_preamble(p: Path) -> tuple[str | None, str | None]:
    """Channel name (``WFID "Ch2, ..."``) and unit (``YUNIT "V"``) of a Tektronix ``.isf``
    file's ASCII preamble (RigolWFM 1.6 names every ISF channel ``CH 1`` and takes its unit as
    volts), ``(None, None)`` for other files."""
    if p.suffix.lower() != ".isf":
        return None, None
    with open(p, "rb") as fh:
        head = fh.read(2048).split(b":CURVE", 1)[0].decode("latin-1")
    m = re.search(r'WFID\s+"\s*(CH\d|MATH\d?|REF\d)', head, re.I)
    u = re.search(r'YUNIT\s+"([^"]*)"', head, re.I)
    return (m.group(1).upper() if m else None), (u.group(1).strip().lower() if u else None)


def _read_binary(paths: list[Path], channels: Any) -> Capture:
    try:
        import RigolWFM.wfm as rwfm  # noqa: PLC0415 -- optional: loaded on first use
    except ImportError:
        raise OptionalDependencyError(
            "RigolWFM", "pip install 'precise_impact[lab]'", "reading binary waveform files"
        ) from None
    data: dict[str, np.ndarray] = {}
    t_ref: np.ndarray | None = None
    dt_ref = None
    instrument = ""
    for p in paths:
        try:
            w = rwfm.Wfm.from_file(str(p), "auto")
        except Exception as e:  # RigolWFM's and kaitai's errors: one line naming the file
            msg = " ".join(str(e).split())[:120] or type(e).__name__
            raise _bad(
                p,
                f"unreadable ({msg})",
                "a binary waveform file RigolWFM reads (damaged or truncated?)",
            ) from None
        instrument = f"{w.header_name} ({w.parser_name})"
        isf_name, isf_unit = _isf_preamble(p)
        for c in w.channels:
            if not getattr(c, "enabled", True) or c.volts is None or c.times is None:
                continue
            unit = isf_unit or getattr(c.unit, "name", str(c.unit)).lower()
            if unit not in ("v", "volt", "volts", "1"):
                raise _bad(p, f"{c.name} in {unit!r}", "channels in V (wrong unit)")
            name = isf_name or str(c.name).upper().replace(" ", "")
            t = np.asarray(c.times, float)
            if t_ref is not None and (len(t) != len(t_ref)):
                raise _bad(
                    p, f"{name}: {len(t)} samples vs {len(t_ref)}", "channels of one acquisition"
                )
            if name in data:
                raise _bad(p, f"channel {name} twice", "one file per channel")
            data[name] = np.asarray(c.volts, float)
            t_ref = t
            dt_ref = float(c.seconds_per_point)
    if t_ref is None:
        raise _bad(paths[0], "no enabled channel", "a waveform file with channels")
    src = {"format": "binary", "instrument": instrument, "reader": "RigolWFM"}
    where = paths[0] if len(paths) == 1 else paths[0].parent
    return _finish(where, t_ref, data, channels, src, dt=dt_ref)


# =============================================================================== writers
def write_capture(capture: Capture, path: str | os.PathLike, fmt: str | None = None) -> Path:
    """Write ``capture`` in one of :data:`WRITE_FORMATS`, in the instrument's own layout.

    Vendor layouts label ``V_s``, ``V_q``, ``V_3`` as ``CH1``, ``CH2``, ``CH3``; ``tek-tbs``
    writes a directory ``path`` holding ``F0000CH1.CSV`` ... (one file per channel).

    Parameters
    ----------
    capture : Capture
        What to write (e.g. from :func:`~precise_impact.lab.synth.synth_capture`).
    path : path
        The file (or, for ``tek-tbs``, the directory) to write.
    fmt : str or None, default ``None``
        One of :data:`WRITE_FORMATS`; ``None``: by suffix (``.npz`` NPZ, ``.bin`` Keysight
        binary, else generic CSV).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ParameterError
        An unknown ``fmt``.

    See Also
    --------
    read_capture : reads every layout written here (and more).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from precise_impact import read_capture, synth_capture, write_capture
    >>> cap = synth_capture(periods=5, transient=5)
    >>> f = write_capture(cap, pathlib.Path(tempfile.mkdtemp()) / "scope.csv", "rigol")
    >>> back = read_capture(f)
    >>> back.source["format"], back.n_samples == cap.n_samples
    ('rigol', True)
    """
    check_type(capture, Capture, "capture", "a Capture (read_capture, synth_capture)")
    return write_layout(capture, path, fmt, UNIFORM_RTOL)
