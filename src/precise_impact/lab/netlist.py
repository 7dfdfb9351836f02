"""Your own netlist: run a user's ngspice/LTspice netlist (or read its ``.raw`` waveforms, with
spicelib's ``RawRead``) and score it against the demonstrated mechanical reference from the same
initial state; the nodes are named by the user (:class:`NodeMap`), volts and seconds map to
``(x, x', tau)`` from the design or from fitted scales.  Details: :doc:`/guide/netlist`.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import subprocess
import tempfile
import time as _time
import tomllib
import types
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.core.budget import Cost, check_cost, parse_max_time
from precise_impact.core.params import Params, check_count
from precise_impact.core.precision import Precision
from precise_impact.core.result import ResultMixin, flat, record_columns
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import (
    BudgetExceededError,
    OptionalDependencyError,
    OverBudgetError,
    ParameterError,
    SpiceError,
    check_type,
)
from precise_impact.io.figures import plot_units, save_figure
from precise_impact.io.jsonout import write_json
from precise_impact.io.progress import say as _progress
from precise_impact.lab.attractor import fit_sinusoid
from precise_impact.lab.capture import integrator_pair_fit_se
from precise_impact.models.circuit.components import Components, circuit_scales, dimensionless
from precise_impact.models.circuit.spice import find_ngspice
from precise_impact.scenes.scene import load_scene
from precise_impact.solvers.simulate import make_solver
from precise_impact.verification.compare import (
    REF_PERTURBATION,
    demonstrated_reference,
    portraits_figure,
    reference_lle,
    score_line,
    separation_figure,
)
from precise_impact.verification.metrics import reference_bits
from precise_impact.verification.scores import detected_period, score

__all__ = [
    "NodeMap",
    "Waveforms",
    "NetlistScoreResult",
    "load_map",
    "read_raw",
    "run_netlist",
    "score_netlist",
    "format_result",
    "fit_forcing",
    "impacts_from_waveform",
    "lt_compression",
    "compress_like_ltspice",
    "NETLIST_SUFFIXES",
    "RAW_SUFFIXES",
    "COMPRESSION_IMPACT_COST",
    "read_netlist",
    "check_nodes",
    "check_periods",
    "tran_cost",
    "NGSPICE_SECONDS_PER_POINT",
    "MAX_PERIODS",
]

#: Netlist file suffixes run through ngspice (``.net``: LTspice's export).
NETLIST_SUFFIXES = (".cir", ".net", ".sp", ".spi", ".ckt")
#: Waveform files read without running anything.
RAW_SUFFIXES = (".raw",)
#: ngspice compatibility mode for LTspice netlists (ngspice >= 39: ``lt`` LTspice syntax, ``ps``
#: PSPICE, ``a`` applied to the whole netlist -- needed for LTspice's B-source functions such as
#: ``uplim``, measured: ``lt`` alone refuses them).
LTSPICE_BEHAVIOR = "ltpsa"
#: What LTspice's default waveform compression costs, measured by ``benchmarks/bench_netlist.py``
#: (``benchmarks/results/netlist.md``) on an *emulation* of LTspice's documented rule
#: (:func:`compress_like_ltspice`, written from LTspice's help page "Compression"), not on
#: LTspice output (no LTspice was run): the project's netlist of fig6-period3-ideal, 20
#: periods, dense ngspice waveform (TMAX 1 us, 171111 points) compressed with LTspice's default
#: tolerances (1.5 % of the points kept).  Impact times: unchanged when read
#: from the polarity node (the steep edge keeps its points), 1.7e-8 tau from the velocity
#: reversal alone; impact velocity 6.9e-7; the stroboscopic states, read inside the compressed
#: linear segments (up to 0.19 tau long), are off by up to 4.4e-3 -- that is the real cost: the
#: same run scored from the compressed file has sliced W 1.5e-3 instead of 1.4e-5 and leaves
#: 1e-3 of the reference after 8.2 time units instead of never.
COMPRESSION_IMPACT_COST = {
    "measured_on": "compress_like_ltspice (an emulation of LTspice's documented rule, not LTspice "
    "output)",
    "max_dt_tau": 1.7e-8,
    "max_dt_s": 1.7e-11,
    "max_dv_before": 6.9e-7,
    "max_state_error": 4.4e-3,
    "points_kept": 0.015,
    "sliced_w_compressed": 1.5e-3,
    "sliced_w_uncompressed": 1.4e-5,
}

_JUMP_SLOPE = 1e3  # |dv/dtau| above this (smooth flight: < ~10) marks an impact's reversal
_SNAP = 1e-9  # a time point within _SNAP * T of a sample time is that sample (breakpoints)


def _need_spicelib():
    try:
        from spicelib import RawRead  # noqa: PLC0415 -- optional: loaded on first use
    except ImportError as e:  # pragma: no cover - spicelib is in the 'lab' extra
        raise OptionalDependencyError(
            "spicelib", "pip install 'precise_impact[lab]'", "reading SPICE .raw files"
        ) from e
    return RawRead


# ================================================================== mapping
@dataclasses.dataclass
class NodeMap:
    """Which nodes carry position, velocity, forcing (and optionally the impact logic), how
    their volts are corrected, and the design/parameters the run should realise.

    Attributes
    ----------
    x, v : str
        Nodes of ``V_s`` (``x = -V_s / V_unit``) and ``V_q`` (``x' = V_q / (omega R8 C1 V_unit)``).
    forcing : str or None
        Node of the forcing ``V_3 = V_A cos(Omega t + phi)``: its frequency, amplitude and
        phase are fitted (needed for fitted scales; gives the phase otherwise).
    impact : str or None
        A logic node that toggles at each impact (the project's ``pol``): impact times are its
        mid-level crossings; without it they are found from the velocity's reversal.
    gains, offsets : dict
        ``V = gain * V_node + offset`` per role (``'x'``, ``'v'``, ``'forcing'``), e.g. a probe.
    components : dict
        Design component values (``Components.make`` names: ``R1`` .. ``R8``, ``C1``, ``C2``,
        ``V_A``, ``Omega``, ``V_wall``, ``V_unit``).
    parameters : dict
        Mechanical parameters (``zeta``, ``a``, ``eta``, ``x_w``, ``R``) when there is no design.
    scene : str or None
        A scene whose parameters and design are the target.
    forcing_gain : float
        ``R7 / R1`` for fitted scales (``V_unit = V_A R7 / (R1 a)``); 1 in the paper's design.
    forcing_phase : float or None
        Phase of ``V_3`` in rad at SPICE time 0, instead of the fitted one.

    See Also
    --------
    precise_impact.lab.netlist.load_map : reads one from TOML.
    precise_impact.lab.netlist.score_netlist : uses it.
    """

    x: str
    v: str
    forcing: str | None = None
    impact: str | None = None
    gains: dict = dataclasses.field(default_factory=dict)
    offsets: dict = dataclasses.field(default_factory=dict)
    components: dict = dataclasses.field(default_factory=dict)
    parameters: dict = dataclasses.field(default_factory=dict)
    scene: str | None = None
    forcing_gain: float = 1.0
    forcing_phase: float | None = None

    def corrected(self, role: str, volts: np.ndarray) -> np.ndarray:
        """``gain * volts + offset`` of ``role``."""
        return float(self.gains.get(role, 1.0)) * volts + float(self.offsets.get(role, 0.0))


_MAP_KEYS = {"nodes", "gains", "offsets", "components", "parameters", "scene", "scales"}


def load_map(path: str | Path) -> NodeMap:
    r"""A :class:`NodeMap` from a TOML file.

    The file::

        scene = "fig6-period3-ideal"       # optional: target parameters and design
        [nodes]
        x = "s"                            # V_s
        v = "q"                            # V_q
        forcing = "v3"                     # optional: V_3
        impact = "pol"                     # optional: a logic node toggling at each impact
        [gains]                            # optional: V = gain * V_node + offset
        x = 1.0
        [offsets]
        v = 0.0
        [components]                       # optional design values (Components.make names)
        R3 = "10e3"
        [parameters]                       # optional, when there is no design
        eta = "0.74"
        [scales]
        forcing_gain = 1.0                 # R7/R1 for fitted scales
        forcing_phase = 0.0                # rad, instead of the fitted phase

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Returns
    -------
    NodeMap
        The nodes, corrections and target it names.

    Raises
    ------
    ParameterError
        Unreadable file, unknown table or key, missing ``x``/``v`` node (one line).

    See Also
    --------
    precise_impact.lab.netlist.score_netlist : takes it as ``map=``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from precise_impact.lab.netlist import load_map
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "map.toml").write_text('[nodes]\nx = "s"\nv = "q"\nforcing = "v3"\n')
    >>> m = load_map(d / "map.toml")
    >>> m.x, m.v, m.forcing
    ('s', 'q', 'v3')
    """
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text())
    except (OSError, UnicodeDecodeError) as e:
        raise ParameterError("map", str(p), f"a readable TOML file ({e.__class__.__name__})") from e
    except tomllib.TOMLDecodeError as e:
        raise ParameterError("map", str(p), f"valid TOML ({e})") from e
    unknown = sorted(set(data) - _MAP_KEYS)
    if unknown:
        raise ParameterError(
            f"map.{unknown[0]}", data[unknown[0]], "one of " + ", ".join(sorted(_MAP_KEYS))
        )
    nodes = data.get("nodes", {})
    bad = sorted(set(nodes) - {"x", "v", "forcing", "impact"})
    if bad:
        raise ParameterError(f"map.nodes.{bad[0]}", nodes[bad[0]], "x, v, forcing or impact")
    for k in ("x", "v"):
        if not isinstance(nodes.get(k), str):
            raise ParameterError(f"map.nodes.{k}", nodes.get(k), "a node name (string)")
    sc = data.get("scales", {})
    return NodeMap(
        x=nodes["x"],
        v=nodes["v"],
        forcing=nodes.get("forcing"),
        impact=nodes.get("impact"),
        gains=_numbers(data.get("gains", {}), "map.gains"),
        offsets=_numbers(data.get("offsets", {}), "map.offsets"),
        components=dict(data.get("components", {})),
        parameters=dict(data.get("parameters", {})),
        scene=data.get("scene"),
        forcing_gain=float(sc.get("forcing_gain", 1.0)),
        forcing_phase=None if sc.get("forcing_phase") is None else float(sc["forcing_phase"]),
    )


def _numbers(d: Mapping, where: str) -> dict:
    out = {}
    for k, v in d.items():
        if k not in ("x", "v", "forcing"):
            raise ParameterError(f"{where}.{k}", v, "x, v or forcing")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ParameterError(f"{where}.{k}", v, "a finite number")
        if where.endswith("gains") and v == 0:
            raise ParameterError(
                f"{where}.{k}", v, "a non-zero finite number (gain must be non-zero)"
            )
        out[k] = float(v)
    return out


# ================================================================== raw files
@dataclasses.dataclass
class Waveforms:
    """One transient run read from a raw file (one plot, one step).

    Attributes
    ----------
    time : numpy array
        Seconds.
    traces : dict
        Lower-case trace name -> ``(values, kind)`` (``kind``: ``'voltage'``, ``'current'``...).
    label : str
        ``'plot P step S'`` (with the step's parameter values for stepped LTspice runs).
    dialect, path : str
        Which simulator wrote the file, and the file.
    header : dict
        The raw file's header lines.
    precision : str
        ``'float32'`` when the traces are stored in single precision (LTspice's default; its
        ``.options numdgt=7`` stores doubles), else ``'float64'``.

    See Also
    --------
    precise_impact.lab.netlist.read_raw : returns them.
    """

    time: np.ndarray
    traces: dict
    label: str
    dialect: str
    path: str
    header: dict
    precision: str = "float64"

    def node(self, name: str, role: str) -> np.ndarray:
        """The voltage of node ``name`` (``'s'``, ``'v(s)'``, any case); :class:`ParameterError`
        naming ``role`` when it is missing or not a voltage."""
        key = name.strip().lower()
        cands = [key] if key.startswith(("v(", "i(")) else [f"v({key})", key]
        for c in cands:
            if c in self.traces:
                vals, kind = self.traces[c]
                if kind != "voltage":
                    raise ParameterError(
                        f"{role}-node", name, f"a node voltage ({c!r} in {self.path} is a {kind})"
                    )
                return vals
        volts = sorted(k for k, (_, kd) in self.traces.items() if kd == "voltage")
        shown = ", ".join(volts[:12]) + (" ..." if len(volts) > 12 else "")
        raise ParameterError(
            f"{role}-node", name, f"a node of {Path(self.path).name} (its voltages: {shown})"
        )


def read_raw(path: str | Path, step: int | None = None) -> list[Waveforms]:
    r"""The transient runs of a ``.raw`` file (LTspice, ngspice, QSPICE; binary or ASCII).

    Read with spicelib's ``RawRead`` (module docstring: what was measured, why it was chosen).

    Parameters
    ----------
    path : str or Path
        The ``.raw`` file.
    step : int or None, default ``None``
        Only this run (0-based over the file's plots and steps, in file order); ``None``: all.

    Returns
    -------
    list of Waveforms
        One per plot and step (a stepped LTspice run, or several plots in one ngspice file).

    Raises
    ------
    ParameterError
        One line naming the problem: missing/empty/truncated/garbage file, not a transient
        analysis, complex data, ``step`` out of range.

    See Also
    --------
    precise_impact.lab.netlist.score_netlist : scores them.
    precise_impact.lab.netlist.run_netlist : writes one by running a netlist.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from precise_impact.lab.netlist import read_raw, run_netlist
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> net = d / "rc.cir"
    >>> _ = net.write_text("* RC\nV1 in 0 SIN(0 1 1k)\nR1 in out 1k\nC1 out 0 100n\n"
    ...                    ".tran 1u 2m\n.end\n")
    >>> _ = run_netlist(net, workdir=d)
    >>> (run,) = read_raw(d / "user.raw")
    >>> run.dialect, run.node("out", "x").shape == run.time.shape
    ('ngspice', True)
    """
    check_type(path, (str, os.PathLike), "path", "a .raw file's path (str or os.PathLike)")
    RawRead = _need_spicelib()
    p = Path(path)
    _check_file(p, RAW_SUFFIXES, "raw file")
    rr = None
    last: Exception | None = None
    for dialect in (None, "ngspice", "ltspice"):
        try:
            rr = RawRead(str(p), dialect=dialect, verbose=False)
            break
        except Exception as e:  # spicelib raises several types for unreadable input
            last = e
    if rr is None:
        msg = " ".join(str(last).split())[:160]
        raise ParameterError("raw file", str(p), f"a SPICE raw file spicelib can read ({msg})")
    return _runs(rr, p, step)


def _check_file(p: Path, suffixes: tuple, what: str) -> None:
    if p.suffix.lower() not in suffixes:
        raise ParameterError(
            "file", str(p), f"a {what} ({', '.join(suffixes)}); unknown extension {p.suffix!r}"
        )
    if not p.is_file():
        raise ParameterError("file", str(p), f"an existing {what}")
    if p.stat().st_size == 0:
        raise ParameterError("file", str(p), f"a {what}; this file is empty")


def _runs(rr: Any, p: Path, step: int | None) -> list[Waveforms]:
    try:
        runs = _read_runs(rr, p)
    except ParameterError:
        raise
    except Exception as e:  # spicelib reads lazily: a truncated data section fails here
        msg = " ".join(str(e).split())[:160]
        raise ParameterError("raw file", str(p), f"an undamaged raw file ({msg})") from e
    for w in runs:
        n = len(w.time)
        if n < 3 or not np.all(np.isfinite(w.time)) or np.any(np.diff(w.time) < 0):
            raise ParameterError(
                "raw file",
                str(p),
                f"time increasing through >= 3 finite points ({w.label}: damaged or truncated)",
            )
        expect = props_points(w.header)
        if expect is not None and expect != n and w.dialect != "ltspice":
            raise ParameterError(
                "raw file", str(p), f"{expect} points as its header says; {n} read (truncated)"
            )
    if step is not None:
        if isinstance(step, bool) or not isinstance(step, int) or not 0 <= step < len(runs):
            raise ParameterError(
                "step", step, f"an integer 0 .. {len(runs) - 1} (runs in the file)"
            )
        return [runs[step]]
    return runs


def _read_runs(rr: Any, p: Path) -> list[Waveforms]:
    """Every plot and step of ``rr`` as :class:`Waveforms`."""
    runs: list[Waveforms] = []
    for pi_, plot in enumerate(rr.plots):
        props = dict(plot.get_raw_properties()) if hasattr(plot, "get_raw_properties") else {}
        names = list(plot.get_trace_names())
        if not names:
            continue
        axis = plot.get_trace(0)
        kind0 = str(getattr(axis, "whattype", "") or "").lower()
        if names[0].lower() != "time" and kind0 != "time":
            raise ParameterError(
                "raw file",
                str(p),
                f"a transient analysis (its plot {pi_} {props.get('Plotname', '')!r} runs over "
                f"{names[0]!r}, not time)",
            )
        if "complex" in str(props.get("Flags", "")).lower():
            raise ParameterError("raw file", str(p), "real transient data (this one is complex)")
        steps = list(plot.get_steps()) if hasattr(plot, "get_steps") else [0]
        step_info = getattr(plot, "steps", None)
        for s in steps:
            t = np.abs(np.asarray(plot.get_wave(0, s), dtype=float))  # LTspice: sign flags
            traces = {}
            single = False
            for j, n in enumerate(names[1:], start=1):
                tr = plot.get_trace(j)
                vals = np.asarray(plot.get_wave(j, s))
                single = single or vals.dtype == np.float32  # LTspice's default (numdgt <= 6)
                if np.iscomplexobj(vals):
                    raise ParameterError("raw file", str(p), "real transient data (complex trace)")
                traces[n.lower()] = (vals.astype(float), str(tr.whattype).lower())
            label = f"plot {pi_} step {s}"
            if step_info and s < len(step_info):
                label += " (" + ", ".join(f"{k}={v}" for k, v in step_info[s].items()) + ")"
            prec = "float32" if single else "float64"
            runs.append(Waveforms(t, traces, label, str(rr.dialect), str(p), props, prec))
    if not runs:
        raise ParameterError("raw file", str(p), "a raw file with at least one plot")
    return runs


def props_points(header: Mapping) -> int | None:
    try:
        return int(str(header.get("No. Points", "")).strip())
    except ValueError:
        return None


# ================================================================== running
def _prepare_netlist(text: str, base: Path) -> tuple[str, list[str]]:
    """The netlist ngspice runs in batch mode with ``-r``: ``.control`` blocks removed (their
    ``quit`` would stop before the raw file is written), LTspice's ``.tran 0 TSTOP`` given a
    step, relative ``.include`` / ``.lib`` paths made absolute from ``base`` (the netlist's own
    directory: the copy runs elsewhere); the notes saying what was changed."""
    notes: list[str] = []
    out: list[str] = []
    in_ctrl = False
    for line in text.splitlines():
        low = line.strip().lower()
        if low.startswith(".control"):
            in_ctrl = True
            note = "its .control block was not run (the .tran line is)"
            if note not in notes:
                notes.append(note)
            continue
        if in_ctrl:
            if low.startswith(".endc"):
                in_ctrl = False
            continue
        if low.startswith(".backanno"):
            continue
        m = re.match(r"(\s*\.(?:include|inc|lib)\s+)(\"[^\"]+\"|'[^']+'|\S+)(.*)$", line, re.I)
        if m and not Path(m.group(2).strip("\"'")).is_absolute():
            path = (base / m.group(2).strip("\"'")).resolve()
            line = f'{m.group(1)}"{path}"{m.group(3)}'
        if low.startswith(".tran"):
            tok = line.split()
            nums = [t for t in tok[1:] if not t.lower().startswith(("uic", "startup", "steady"))]
            if len(nums) == 1 or (len(nums) >= 2 and _spice_number(nums[0]) == 0):
                tstop = nums[0] if len(nums) == 1 else nums[1]
                step = _spice_number(tstop) / 10000
                rest = nums[2:] if len(nums) >= 2 else []
                flags = [t for t in tok[1:] if t not in nums]
                line = " ".join([".tran", repr(step), tstop, *rest, *flags])
                notes.append(f".tran step 0 given {step:g} s for ngspice")
        out.append(line)
    return "\n".join(out) + "\n", notes


_SUFFIX = {
    "t": 1e12,
    "g": 1e9,
    "meg": 1e6,
    "k": 1e3,
    "m": 1e-3,
    "u": 1e-6,
    "µ": 1e-6,
    "n": 1e-9,
    "p": 1e-12,
    "f": 1e-15,
}


def _spice_number(s: str) -> float:
    m = re.fullmatch(r"([-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?)(meg|[tgkmuµnpf])?[a-z]*", s.lower())
    if not m:
        return math.nan
    return float(m.group(1)) * _SUFFIX.get(m.group(2) or "", 1.0)


def _is_ltspice(p: Path, text: str) -> bool:
    head = text[:400].lower()
    return p.suffix.lower() == ".net" or ".backanno" in text.lower() or ".asc" in head


#: ngspice's wall time per transient time point, measured on the project's netlist of
#: fig6-period3-ideal (ngspice-39, 20 periods: 18340 points in 0.51 s at TMAX 10 us, 171111
#: in 4.7 s at 1 us: 2.8e-5 s each), rounded up; a user's larger circuit costs more per point.
NGSPICE_SECONDS_PER_POINT = 3e-5


def read_netlist(path: str | Path) -> str:
    """The text of a netlist file (UTF-8, or LTspice's UTF-16), with one ``.tran``; else one
    line (:class:`ParameterError`)."""
    p = Path(path)
    _check_file(p, NETLIST_SUFFIXES, "SPICE netlist")
    try:
        text = p.read_text(errors="strict")
    except UnicodeDecodeError:
        text = p.read_bytes().decode("utf-16", errors="replace")
        if "\x00" in text or not text.strip():
            raise ParameterError("file", str(p), "a text netlist (this one is binary)") from None
    if not re.search(r"^\s*\.tran\b", text, re.I | re.M):
        raise ParameterError("file", str(p), "a netlist with a .tran analysis (none found)")
    return text


def _element_lines(text: str) -> list[list[str]]:
    """The tokens of the netlist's element lines (``+`` continuations joined; comments,
    dot commands and ``.control`` blocks left out), lower case."""
    lines: list[str] = []
    in_ctrl = False
    for raw in text.splitlines()[1:]:  # SPICE: the first line is the title
        line = raw.split(";")[0].strip()
        low = line.lower()
        if low.startswith(".control"):
            in_ctrl = True
        if in_ctrl:
            in_ctrl = not low.startswith(".endc")
            continue
        if not line or line.startswith("*"):
            continue
        if line.startswith("+") and lines:
            lines[-1] += " " + line[1:]
        elif not line.startswith("."):
            lines.append(line)
    return [re.split(r"[\s,()=]+", ln.lower()) for ln in lines]


def netlist_nodes(text: str) -> set[str]:
    """Every token that can be a node of the netlist's element lines (names, terminals and
    values: a superset of its nodes), lower case."""
    return {t for toks in _element_lines(text) for t in toks[1:] if t}


def check_nodes(text: str, nodes: Mapping[str, str | None], name: str = "netlist") -> None:
    """Refuse, before ngspice runs, a node that appears on none of the netlist's element
    lines (one line naming the role and node).  Nodes given as ``v(name)`` are looked up by
    ``name``; hierarchical names (``x1.out``) and netlists with ``.include`` / ``.lib``
    (nodes defined elsewhere) are not checked: ngspice's output decides for them."""
    if re.search(r"^\s*\.(include|inc|lib)\b", text, re.I | re.M):
        return
    known = netlist_nodes(text)
    for role, node in nodes.items():
        if node is None:
            continue
        key = node.strip().lower()
        m = re.fullmatch(r"v\((.+)\)", key)
        key = m.group(1) if m else key
        if "." in key or ":" in key:  # a node inside a subcircuit (x1.out): not on a top line
            continue
        if key not in known:
            raise ParameterError(
                f"{role}-node", node, f"a node of {name} (it is on none of its element lines)"
            )


def tran_cost(text: str, name: str = "netlist") -> Cost:
    """The size of the netlist's ``.tran`` run: ``TSTOP / min(TSTEP, TMAX)`` time points
    (LTspice's ``TSTEP = 0``: ``TSTOP / 10000``, as :func:`run_netlist` gives it), priced
    at :data:`NGSPICE_SECONDS_PER_POINT`, 8 bytes per point and node (the raw file, read
    into memory).  A lower bound on the points: ngspice adds steps at each breakpoint."""
    m = re.search(r"^\s*\.tran\b(.*)$", text, re.I | re.M)
    toks = m.group(1).split() if m else []
    nums = [
        _spice_number(t) for t in toks if not t.lower().startswith(("uic", "startup", "steady"))
    ]
    nums = [v for v in nums if math.isfinite(v)]
    if not nums:
        return Cost(0.0, 0.0, f"{name}: .tran without a stop time")
    if len(nums) == 1:
        tstep, tstop = nums[0] / 10000, nums[0]
    else:
        tstep, tstop = nums[0], nums[1]
        if tstep == 0:
            tstep = tstop / 10000
    step = min(tstep, nums[3]) if len(nums) > 3 and nums[3] > 0 else tstep
    points = tstop / step if step > 0 else math.inf  # ngspice steps from 0 whatever TSTART
    n_nodes = max(len({t for toks in _element_lines(text) for t in toks[1:3]}), 1)
    return Cost(
        points * NGSPICE_SECONDS_PER_POINT,
        points * 8 * (n_nodes + 1),
        f"{name}: .tran {tstop:g} s in steps of {step:g} s = {points:.3g} time points",
    )


def _run_budget(max_time: Any, timeout: float, text: str, name: str) -> tuple[Any, float]:
    """``(budget, timeout)``: the run's estimate checked against ``max_time`` and the memory."""
    budget = None
    if max_time is not None:
        budget = parse_max_time(max_time)
        cost = tran_cost(text, name)  # before ngspice runs: its time, then its memory
        if cost.seconds > budget:
            raise OverBudgetError(
                "max_time",
                f"{budget:g} s",
                f"a budget above the estimate ({cost.describe()}); raise --max-time or "
                "shorten .tran (TSTOP) or lengthen its step",
            )
        try:
            check_cost(cost, None)  # half the machine's memory: the raw file is read whole
        except OverBudgetError:
            raise OverBudgetError(
                "file",
                name,
                f"a .tran run whose waveforms fit in half this machine's memory "
                f"({cost.describe()}); shorten TSTOP or lengthen the step",
            ) from None
        timeout = min(timeout, budget)
    return budget, timeout


def _call_ngspice(
    exe: str, raw: Path, cir: Path, wd: Path, timeout: float, budget: Any, text: str, name: str
) -> tuple[str, float]:
    """Run ngspice in ``wd``: ``(its log, elapsed s)``; a budget run out or an error raises."""
    t0 = _time.perf_counter()
    try:
        proc = subprocess.run(
            [exe, "-b", "-r", raw.name, cir.name],
            cwd=wd,
            capture_output=True,
            text=True,
            timeout=timeout,
        )
    except subprocess.TimeoutExpired as e:
        # a budget ran out (the CLI: one line, exit 3), whichever of the two it was
        which = "max_time" if budget is not None and timeout == budget else "timeout"
        raise BudgetExceededError(
            f"ngspice did not finish {name} within {which} = {timeout:g} s (estimate: "
            f"{tran_cost(text, name).describe()}); raise --max-time or shorten .tran"
        ) from e
    elapsed = _time.perf_counter() - t0
    log = proc.stdout + proc.stderr
    (wd / "ngspice.log").write_text(log)
    errs = [ln for ln in log.splitlines() if re.search(r"\berror\b|aborted|too small", ln, re.I)]
    if proc.returncode != 0 or not raw.exists() or errs:
        first = (errs or log.strip().splitlines()[-1:] or ["no output"])[0].strip()
        raise SpiceError(f"ngspice could not run {name} (exit {proc.returncode}): {first}")
    return log, elapsed


def run_netlist(
    path: str | Path,
    workdir: str | Path | None = None,
    *,
    ltspice: bool | None = None,
    ascii_raw: bool = False,
    timeout: float = 600,
    executable: str | None = None,
    max_time: float | None = None,
) -> tuple[list[Waveforms], dict]:
    r"""Run a netlist with ``ngspice -b -r`` and read its raw file.

    The netlist is copied into the working directory and run as it is, except: its
    ``.control`` blocks are left out (their ``quit`` stops ngspice before ``-r`` writes the
    file; the ``.tran`` line runs), ``.backanno`` is dropped, and LTspice's ``.tran 0 TSTOP``
    (TSTEP = 0, refused by ngspice) gets TSTEP = TSTOP/10000; each change is a note.

    Parameters
    ----------
    path : str or Path
        ``.cir``, ``.net``, ``.sp`` (``.spi``, ``.ckt``).
    workdir : str, Path or None, default ``None``
        Where the run's files are kept (``user.<ext>``, ``user.raw``, ``ngspice.log``,
        ``.spiceinit``); ``None``: a temporary directory.
    ltspice : bool or None, default ``None``
        Run in ngspice's LTspice compatibility mode (``set ngbehavior=ltpsa`` in a generated
        ``.spiceinit``); ``None``: for ``.net`` files and netlists exported from ``.asc``.
    ascii_raw : bool, default ``False``
        Write the raw file as ASCII (``set filetype=ascii``) instead of binary.
    timeout : float, default 600
        Seconds ngspice may run.
    executable : str or None, default ``None``
        The ngspice program (``None``: ``ngspice`` on ``PATH``).
    max_time : float or None, default ``None``
        A time budget in seconds: the run's size estimated from its ``.tran``
        (:func:`tran_cost`) is refused above it before ngspice starts, and ngspice is
        stopped when it runs out (``None``: only ``timeout``).

    Returns
    -------
    tuple
        ``(runs, info)``: the :class:`Waveforms` and ``{"ngspice_log", "notes",
        "ltspice_mode", "options", "elapsed_s"}``.

    Raises
    ------
    ParameterError
        Unknown extension, empty or binary file, no ``.tran`` analysis.
    OverBudgetError
        The ``.tran`` estimate is over ``max_time`` (or half the memory), before ngspice runs.
    BudgetExceededError
        ngspice ran out of ``timeout`` / ``max_time``.
    NgspiceNotFoundError
        No ngspice.
    SpiceError
        ngspice failed (its first error line).

    See Also
    --------
    precise_impact.lab.netlist.read_raw : reads the file it writes.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from precise_impact.lab.netlist import run_netlist
    >>> net = pathlib.Path(tempfile.mkdtemp()) / "rc.net"      # an LTspice export
    >>> _ = net.write_text("V1 in 0 SINE(0 1 1k)\nR1 in out 1k\nC1 out 0 100n\n"
    ...                    ".tran 0 2m\n.backanno\n.end\n")
    >>> (run,), info = run_netlist(net)
    >>> info["ltspice_mode"], info["notes"]
    ('ltpsa', ['.tran step 0 given 2e-07 s for ngspice'])
    """
    p = Path(path)
    text = read_netlist(p)
    lt = _is_ltspice(p, text) if ltspice is None else bool(ltspice)
    run_text, notes = _prepare_netlist(text, p.resolve().parent)
    exe = find_ngspice(executable)
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not timeout > 0:
        raise ParameterError("timeout", timeout, "seconds > 0")
    budget, timeout = _run_budget(max_time, timeout, text, p.name)
    with tempfile.TemporaryDirectory(prefix="precise_impact_netlist_") as tmp:
        wd = Path(workdir) if workdir is not None else Path(tmp)
        wd.mkdir(parents=True, exist_ok=True)
        cir = wd / ("user" + p.suffix.lower())
        cir.write_text(run_text)
        init = ["set filetype=ascii" if ascii_raw else "set filetype=binary"]
        if lt:
            init.insert(0, f"set ngbehavior={LTSPICE_BEHAVIOR}")
        (wd / ".spiceinit").write_text("\n".join(init) + "\n")
        raw = wd / "user.raw"
        if raw.exists():
            raw.unlink()
        log, elapsed = _call_ngspice(exe, raw, cir, wd, timeout, budget, text, p.name)
        runs = read_raw(raw)
        if workdir is None:
            for w in runs:
                w.path = f"{p.name} (run by ngspice)"
    info = {
        "ngspice_log": log if workdir is None else str(wd / "ngspice.log"),
        "notes": notes,
        "ltspice_mode": LTSPICE_BEHAVIOR if lt else None,
        "options": _options(text),
        "elapsed_s": elapsed,
    }
    if workdir is None:
        info["ngspice_log"] = "\n".join(log.strip().splitlines()[-5:])
    return runs, info


def _options(text: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for line in text.splitlines():
        if line.strip().lower().startswith((".options", ".option", ".opt ")):
            for tok in line.split()[1:]:
                k, _, v = tok.partition("=")
                out[k.lower()] = v
    return out


# ================================================================== LTspice compression
def compress_like_ltspice(
    t: np.ndarray,
    ys: list[np.ndarray],
    reltol: float = 0.0025,
    vntol: float = 1e-5,
    window: int = 300,
) -> np.ndarray:
    """Indices of the points LTspice's default waveform compression keeps.

    LTspice drops points that linear interpolation between the kept ones reproduces within
    ``plotreltol`` (relative) or ``plotvntol`` (absolute, volts) for every saved trace, over
    windows of at most ``plotwinsize`` points (LTspice help, "Compression"); this is that
    rule, greedy from each kept point (``.options plotwinsize=0`` turns LTspice's off).

    Parameters
    ----------
    t : numpy array
        Time points.
    ys : list of numpy arrays
        The saved traces (each as long as ``t``).
    reltol : float, default 0.0025
        ``plotreltol``.
    vntol : float, default 1e-5
        ``plotvntol`` [V].
    window : int, default 300
        ``plotwinsize``.

    Returns
    -------
    numpy array
        Increasing indices into ``t``, first and last included.

    See Also
    --------
    precise_impact.lab.netlist.lt_compression : detects compressed files.

    Examples
    --------
    >>> import numpy as np
    >>> from precise_impact.lab.netlist import compress_like_ltspice
    >>> t = np.linspace(0, 1, 1001)
    >>> len(compress_like_ltspice(t, [2 * t + 1]))  # a line: the ends of each 300-point window
    5
    """
    n = len(t)
    keep = [0]
    i = 0
    while i < n - 1:
        j = min(i + 2, n - 1)
        best = i + 1
        while j < n and j - i <= window:
            ok = True
            for y in ys:
                seg_t = t[i + 1 : j]
                lin = y[i] + (y[j] - y[i]) * (seg_t - t[i]) / (t[j] - t[i])
                tol = np.maximum(reltol * np.abs(y[i + 1 : j]), vntol)
                if np.any(np.abs(y[i + 1 : j] - lin) > tol):
                    ok = False
                    break
            if not ok:
                break
            best = j
            j += 1
        keep.append(best)
        i = best
    return np.asarray(keep)


def lt_compression(runs: list[Waveforms], options: Mapping[str, str] | None = None) -> dict:
    r"""Whether the waveforms are LTspice-compressed, and what that costs.

    LTspice compresses lossily unless ``.options plotwinsize=0`` (window ``plotwinsize`` 300
    points, ``plotreltol``, ``plotvntol``: LTspice's help, page "Compression").  The help does
    not document the raw header; files LTspice writes with compression off carry ``Flags: ...
    nocompression`` (as a third-party raw-file reader reports from LTspice 26.0.2 for macOS;
    not checked here against an LTspice run: there is no LTspice on this machine).  Decided
    from that flag; a netlist's ``.options`` (``options``, or an LTspice ``.net``/``.log``
    beside the raw file) is reported beside it.  Files of other simulators are never compressed.

    Parameters
    ----------
    runs : list of Waveforms
        From :func:`read_raw`.
    options : mapping or None, default ``None``
        The netlist's ``.options`` (name -> value), if known.

    Returns
    -------
    dict
        ``compressed`` (bool), ``why``, ``flags``, ``step_spread`` (largest over median time
        step); compressed: ``cost`` (:data:`COMPRESSION_IMPACT_COST`) and a one-line
        ``warning``.

    See Also
    --------
    precise_impact.lab.netlist.compress_like_ltspice : the compression rule, for measuring.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from precise_impact.lab.netlist import lt_compression, read_raw, run_netlist
    >>> net = pathlib.Path(tempfile.mkdtemp()) / "rc.cir"
    >>> _ = net.write_text("* RC\nV1 in 0 SIN(0 1 1k)\nR1 in out 1k\nC1 out 0 100n\n"
    ...                    ".tran 1u 2m\n.end\n")
    >>> runs, _ = run_netlist(net)
    >>> lt_compression(runs)["compressed"]                    # ngspice never compresses
    False
    """
    w = runs[0]
    opts = dict(options or {})
    src = Path(w.path)
    if not opts:
        for sib in (src.with_suffix(".net"), src.with_suffix(".log")):
            if sib.is_file():
                try:
                    opts = _options(sib.read_text(errors="replace"))
                except OSError:
                    pass
                break
    dt = np.diff(w.time)
    spread = float(np.max(dt) / max(float(np.median(dt)), 1e-300)) if len(dt) else math.nan
    flags = str(w.header.get("Flags", "")).lower().split()
    out: dict[str, Any] = {"step_spread": spread, "flags": " ".join(flags)}
    if opts.get("plotwinsize") is not None:
        out["netlist_plotwinsize"] = opts["plotwinsize"]
    if w.dialect != "ltspice":
        return {"compressed": False, "why": f"written by {w.dialect} (no compression)", **out}
    if "nocompression" in flags:
        return {"compressed": False, "why": "LTspice header flag 'nocompression'", **out}
    cost = COMPRESSION_IMPACT_COST
    return {
        "compressed": True,
        "why": "LTspice file without the header flag 'nocompression' (.options plotwinsize=0)",
        **out,
        "cost": dict(cost),
        "warning": (
            "LTspice compressed this waveform (no 'nocompression' flag; .options "
            "plotwinsize=0 turns it off): on the project's netlist an emulation of LTspice's "
            "documented rule (compress_like_ltspice, not LTspice output) moves impact times by "
            f"~{cost['max_dt_tau']:.0e} tau but the "
            f"stroboscopic states by up to {cost['max_state_error']:.0e} (sliced W "
            f"{cost['sliced_w_compressed']:.1e} instead of {cost['sliced_w_uncompressed']:.1e}); "
            "rerun with .options plotwinsize=0"
        ),
    }


# ================================================================== fits
def fit_forcing(t: np.ndarray, y: np.ndarray, omega_guess: float | None = None) -> dict:
    """Fit ``y = A cos(W t + phi) + C`` by time-weighted least squares (Gauss-Newton on ``W``).

    Each point is weighted by the time it stands for (half its two intervals), so a
    simulator's dense steps near an impact do not dominate.

    Parameters
    ----------
    t : numpy array
        Time [s], increasing.
    y : numpy array
        The forcing node's voltage.
    omega_guess : float or None, default ``None``
        Starting ``W`` [rad/s]; ``None``: from the upward mean crossings.

    Returns
    -------
    dict
        ``Omega`` [rad/s], ``amplitude``, ``phase`` (rad at t = 0, in (-pi, pi]), ``offset``
        with their standard errors (``*_stderr``, from the weighted residual and the Jacobian)
        and ``rms_residual``.

    Raises
    ------
    ParameterError
        Fewer than two forcing cycles.

    See Also
    --------
    precise_impact.lab.netlist.score_netlist : fitted scales use it.

    Examples
    --------
    >>> import numpy as np
    >>> from precise_impact.lab.netlist import fit_forcing
    >>> t = np.linspace(0, 0.05, 4001)
    >>> f = fit_forcing(t, 2.0 * np.cos(740.0 * t + 0.3))
    >>> round(f["Omega"], 9), round(f["amplitude"], 9), round(f["phase"], 9)
    (740.0, 2.0, 0.3)
    """
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    w = np.empty_like(t)
    w[1:-1] = (t[2:] - t[:-2]) / 2
    w[0], w[-1] = (t[1] - t[0]) / 2, (t[-1] - t[-2]) / 2
    if omega_guess is None:
        s = y - y.mean()
        up = np.nonzero((s[:-1] < 0) & (s[1:] >= 0))[0]
        if len(up) < 2:
            raise ParameterError(
                "forcing-node", "", "a periodic forcing with >= 2 cycles in the run"
            )
        tc = t[up] - s[up] * (t[up + 1] - t[up]) / (s[up + 1] - s[up])
        omega_guess = 2 * math.pi * (len(tc) - 1) / (tc[-1] - tc[0])
    # the one sinusoid fitter (lab.attractor.fit_sinusoid), weighted by the time each point
    # stands for; its covariance is [c, a, b, W] about the centre time tm
    fit = fit_sinusoid(t, y, float(omega_guess), harmonics=1, weights=w)
    W, tm, cov = float(fit["omega"]), float(fit["tm"]), fit["cov"]
    a, b, c0 = float(fit["a_centred"][0]), float(fit["b_centred"][0]), float(fit["c"])
    amp = math.hypot(a, b)
    # a cos + b sin = amp cos(W(t - tm) - atan2(b, a)): the phase at t = 0
    phase = math.remainder(-math.atan2(b, a) - W * tm, 2 * math.pi)
    var_ab = np.asarray(cov[1:3, 1:3], float)
    ga = np.array([a, b]) / amp if amp > 0 else np.zeros(2)
    gp = np.array([b, -a]) / amp**2 if amp > 0 else np.zeros(2)
    sW = math.sqrt(max(float(cov[3, 3]), 0.0))
    return {
        "Omega": W,
        "Omega_stderr": sW,
        "amplitude": amp,
        "amplitude_stderr": math.sqrt(max(float(ga @ var_ab @ ga), 0.0)),
        "phase": phase,
        "phase_stderr": math.hypot(math.sqrt(max(float(gp @ var_ab @ gp), 0.0)), sW * abs(tm)),
        "offset": c0,
        "offset_stderr": math.sqrt(max(float(cov[0, 0]), 0.0)),
        "rms_residual": float(fit["rms"]),
    }


# ================================================================== scoring
@dataclasses.dataclass
class NetlistScoreResult(ResultMixin):
    """What :func:`score_netlist` returns.

    Attributes
    ----------
    source, kind : str
        The file and ``'netlist'`` (run here by ngspice) or ``'raw'`` (read).
    dialect : str
        The simulator that wrote the waveforms.
    params : dict
        Target parameters (exact decimals) the reference realises (initial state: the first
        sample, mapped).
    mapping : dict
        ``mode`` (``'components'`` / ``'fitted'``), ``omega`` [rad/s], ``seconds_per_tau``,
        ``volts_per_x``, ``volts_per_v`` and, fitted, their standard errors.
    forcing : dict or None
        The forcing fit (:func:`fit_forcing`) when a forcing node was given.
    reference, lle : dict
        How the reference was made (:mod:`~precise_impact.verification.compare`) and its LLE.
    runs : list of dict
        Per plot/step: ``label``, ``points``, ``periods``, ``initial_state``, ``regime``,
        ``scores`` (:func:`~precise_impact.verification.scores.score`), sampling notes.
    compression : dict
        :func:`lt_compression`.
    warnings : list of str
        One line each.
    ngspice : dict or None
        For a netlist run here: ``ltspice_mode`` (the ``ngbehavior`` used or ``None``),
        ``elapsed_s``, ``log`` (the tail of ngspice's output), the netlist's ``options``.
    files : list of str or None
        Figures written.

    See Also
    --------
    precise_impact.lab.netlist.score_netlist : returns it.
    precise_impact.verification.compare.CompareResult : the built-in models' counterpart.
    """

    source: str
    kind: str
    dialect: str
    params: dict
    mapping: dict
    forcing: dict | None
    reference: dict
    lle: dict
    runs: list
    compression: dict
    warnings: list
    ngspice: dict | None = None
    files: list | None = None
    _plots: dict = dataclasses.field(default_factory=dict, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """Every field but the trajectories kept for :meth:`plot` (strict JSON)."""
        return {
            f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "_plots"
        }

    def _tables(self) -> dict:
        """``to_dataframe()`` table ``runs``: one row per run (plot/step), its start and its
        scalar scores (nested ones as ``horizons.0.001``, ``divergence.rate`` ...)."""
        return {
            "runs": lambda: record_columns(
                [
                    {
                        "name": r["name"],
                        "periods": r["periods"],
                        "regime": r["regime"],
                        **flat(r["initial_state"]),
                        **flat(r["scores"]),
                    }
                    for r in self.runs
                ]
            )
        }

    def plot(
        self,
        path: str | Path | None = None,
        what: str = "portraits",
        units: str = "dimensionless",
        run: int = 0,
    ):
        """One run (``run``, index into :attr:`runs`) and its reference in the phase plane
        (``what='portraits'``) or its separation from the reference against time
        (``'separation'``), drawn by :mod:`precise_impact.verification.compare`'s figure
        functions.

        Parameters
        ----------
        path : str, Path or None, default ``None``
            Where to save it (format from the suffix); ``None``: only returned.
        what : {'portraits', 'separation'}, default ``'portraits'``
            Which figure.
        units : {'dimensionless', 'circuit'}, default ``'dimensionless'``
            Axes (``'circuit'`` needs a design).
        run : int, default 0
            Which run of a stepped or multi-plot file.

        Returns
        -------
        matplotlib.figure.Figure
            The figure.
        """

        if what not in ("portraits", "separation"):
            raise ParameterError("what", what, "'portraits' or 'separation'")
        pl = self._plots
        if isinstance(run, bool) or not isinstance(run, int) or not 0 <= run < len(pl["runs"]):
            raise ParameterError("run", run, f"an integer 0 .. {len(pl['runs']) - 1}")
        r = pl["runs"][run]
        design = pl.get("design")
        u = plot_units(units, components=design if units == "circuit" else None)
        # compare's figure functions read the scene's name and parameters only
        scene = types.SimpleNamespace(name=f"{r['name']} vs {pl['target']}", params=r["ref"].params)
        results = {r["name"]: self.runs[run]["scores"]}
        trajs = {r["name"]: r["traj"]}
        if what == "portraits":
            fig = portraits_figure(scene, r["ref"], trajs, pl["k"], results, u)
        else:
            fig = separation_figure(scene, r["ref"], r["check"], trajs, self.lle["lle"], results, u)
        if path is not None:
            save_figure(fig, path)
        return fig


def _target(nmap: NodeMap, scene: str | None):
    """``(params, design or None, scene name)`` from the scene, the map's components or its
    parameters."""

    name = scene or nmap.scene
    if name is not None:
        sc = load_scene(name)
        if sc.kind != "single":
            raise ParameterError("scene", sc.name, "a single-oscillator scene")
        design = sc.design()
        if nmap.components:
            design = design.replace(**nmap.components)
        params = sc.params if not nmap.parameters else sc.params.replace(**nmap.parameters)
        return params, design, sc.name
    if nmap.components:
        try:
            design = Components.make(**nmap.components)
        except ParameterError as e:
            raise ParameterError(
                f"map.components.{e.name}",
                e.value,
                f"{e.allowed} (without a scene [components] is the whole design: R1 .. R8, C1, "
                "C2, V_A, Omega, V_wall; or give scene = ... and only the values that differ)",
            ) from e
        return dimensionless(design), design, "user design"
    if nmap.parameters:
        return Params.make(**nmap.parameters), None, "user parameters"
    raise ParameterError(
        "scene",
        None,
        "a scene (--scene) or [components] / [parameters] in the --map file: the "
        "target the circuit should realise",
    )


#: Smallest R^2 of ``V_s = c - integral V_q dt / (R8 C1)`` for the x and v nodes to be taken as
#: the integrator pair (the project's netlist: 1 - 1e-10; x and v swapped or a wrong node: far
#: below, or a negative R8 C1).
INTEGRATOR_MIN_R2 = 0.9
#: Largest rms residual of the forcing fit, relative to its amplitude (a source: ~1e-15).
FORCING_MAX_RESIDUAL = 0.05


def _check_channels(w: Waveforms, nmap: NodeMap, vs: np.ndarray, vq: np.ndarray) -> None:
    """The x and v nodes are an integrator pair (``V_s' = -V_q / (R8 C1)``, R8 C1 > 0), or one
    line saying which way they are not."""
    rc, r2, _ = integrator_pair_fit_se(w.time, vs, vq)
    if r2 >= INTEGRATOR_MIN_R2 and rc < 0:
        raise ParameterError(
            "x-node",
            nmap.x,
            f"the integrator output of v-node {nmap.v!r} (V_x' = -V_v/(R8 C1) with R8 C1 > 0; "
            f"fitted R8 C1 = {rc:.3g} s: x and v swapped, or a sign flipped -- a gain of -1 "
            "in [gains] corrects an inverted probe)",
        )
    if not r2 >= INTEGRATOR_MIN_R2 or not math.isfinite(rc):
        raise ParameterError(
            "x-node",
            nmap.x,
            f"the integral of v-node {nmap.v!r} (V_x' = -V_v/(R8 C1)): the fit explains "
            f"{max(r2, 0.0):.0%} of V_x ({INTEGRATOR_MIN_R2:.0%} needed): x and v swapped, or "
            "a wrong channel?",
        )


def _mapping(
    params: Params, design, mode: str, w: Waveforms, nmap: NodeMap, vs, vq
) -> tuple[dict, dict | None]:
    """The volts/seconds -> (x, v, tau) scales and the forcing fit; wrong channels refused."""
    _check_channels(w, nmap, vs, vq)
    fit = None
    if nmap.forcing is not None:
        f = nmap.corrected("forcing", w.node(nmap.forcing, "forcing"))
        guess = float(design.Omega) if design is not None else None
        fit = fit_forcing(w.time, f, guess)
        rel = fit["rms_residual"] / max(fit["amplitude"], 1e-300)
        if not rel < FORCING_MAX_RESIDUAL:
            raise ParameterError(
                "forcing-node",
                nmap.forcing,
                f"a sinusoidal forcing node (the fit leaves {rel:.0%} of its amplitude; "
                f"{FORCING_MAX_RESIDUAL:.0%} allowed)",
            )
    if mode == "auto":
        mode = "components" if design is not None else "fitted"
    if mode == "components":
        if design is None:
            raise ParameterError(
                "scales", mode, "'fitted' (no design: give a scene or [components])"
            )
        cs = circuit_scales(design)
        m = {
            "mode": "components",
            "omega": cs.omega,
            "seconds_per_tau": cs.seconds_per_tau,
            "volts_per_x": cs.volts_per_x,
            "volts_per_v": cs.volts_per_v,
            "how": "circuit_scales of the design values (as to_mechanical)",
        }
        if fit is not None:
            m["forcing_Omega_vs_design"] = fit["Omega"] / float(design.Omega) - 1
        return m, fit
    if mode != "fitted":
        raise ParameterError("scales", mode, "'auto', 'components' or 'fitted'")
    if fit is None:
        raise ParameterError("forcing-node", None, "a forcing node for fitted scales")
    eta, a = float(params.eta), float(params.a)
    omega = fit["Omega"] / eta
    vu = fit["amplitude"] * nmap.forcing_gain / a
    # one segment (a simulator's noise-free run); the reversals take nanoseconds: the
    # trapezoid integral crosses them without error worth the name
    rc, _, rc_se = integrator_pair_fit_se(w.time, vs, vq)
    # the trapezoid integral's own error, relative (omega h)^2 / 12 for a sinusoid at omega;
    # doubled for the impacts' higher harmonics (measured: 1.4e-5 at h = 1e-5 s, omega = 1e3)
    h = float(np.max(np.diff(w.time)))
    rc_se = math.hypot(rc_se, abs(rc) * (omega * h) ** 2 / 6)
    m = {
        "mode": "fitted",
        "omega": omega,
        "omega_stderr": fit["Omega_stderr"] / eta,
        "seconds_per_tau": 1 / omega,
        "V_unit": vu,
        "V_unit_stderr": fit["amplitude_stderr"] * nmap.forcing_gain / a,
        "R8C1": rc,
        "R8C1_stderr": rc_se,
        "R8C1_how": "least squares of V_s on the trapezoid integral of V_q; error: the fit's "
        "standard error and the trapezoid bound (omega h_max)^2 / 6",
        "volts_per_x": -vu,
        "volts_per_v": omega * rc * vu,
        "how": "omega = Omega_fit / eta, V_unit = A_fit (R7/R1) / a, R8 C1 from "
        "V_s' = -V_q/(R8 C1)",
    }
    return m, fit


def impacts_from_waveform(tau, x, v, aux_t=None, aux=None):
    """Impacts of a mapped waveform (dimensionless ``tau``, ``x``, ``v``).

    An impact is a group of intervals with ``dv/dtau < -1000`` (free flight: below ~10);
    its time is the logic node's mid-level crossing nearest to it (``aux``) or v's zero
    crossing inside the group; v before/after are extrapolated linearly from the two points
    on each side of the group.

    Parameters
    ----------
    tau, x, v : numpy arrays
        The mapped waveform.
    aux_t, aux : numpy arrays or None, default ``None``
        Times and values of a logic node toggling at each impact.

    Returns
    -------
    tuple of numpy arrays
        ``(t, v_before, v_after)``.
    """
    dtau = np.diff(tau)
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.where(dtau > 0, np.diff(v) / dtau, -np.inf * np.sign(np.diff(v)))
    jump = np.nonzero(slope < -_JUMP_SLOPE)[0]
    groups: list[list[int]] = []
    for i in jump:
        if groups and (i - groups[-1][-1] <= 3 or tau[i] - tau[groups[-1][-1] + 1] < 1e-4):
            groups[-1].append(int(i))
        else:
            groups.append([int(i)])
    cross_t = None
    if aux is not None:
        mid = 0.5 * (np.max(aux) + np.min(aux))
        s = aux - mid
        c = np.nonzero((s[:-1] < 0) != (s[1:] < 0))[0]
        cross_t = aux_t[c] + s[c] / (s[c] - s[c + 1]) * (aux_t[c + 1] - aux_t[c])
    ti, vb, va = [], [], []
    n = len(tau)
    for g in groups:
        i0, i1 = g[0], g[-1] + 1
        if i0 < 1 or i1 + 1 >= n:
            continue
        if cross_t is not None and len(cross_t):
            j = int(np.argmin(np.abs(cross_t - 0.5 * (tau[i0] + tau[i1]))))
            tc = float(cross_t[j])
        else:
            seg = v[i0 : i1 + 1]
            k = np.nonzero((seg[:-1] > 0) & (seg[1:] <= 0))[0]
            if not len(k):
                continue
            a = i0 + int(k[0])
            tc = float(tau[a] - v[a] * (tau[a + 1] - tau[a]) / (v[a + 1] - v[a]))
        vb.append(_lin(tau, v, i0 - 1, i0, tc))
        va.append(_lin(tau, v, i1, i1 + 1, tc))
        ti.append(tc)
    return np.asarray(ti), np.asarray(vb), np.asarray(va)


def _lin(ts, ys, i0, i1, t):
    if ts[i1] == ts[i0]:
        return float(ys[i1])
    return float(ys[i1] + (ys[i1] - ys[i0]) * (t - ts[i1]) / (ts[i1] - ts[i0]))


def _samples(ts: np.ndarray, period_s: float, t_first: float, periods: int | None):
    """Sample times ``k period_s`` (k from the first one inside the run), the values' indices
    or interpolation weights; at most ``periods`` + 1 samples."""
    k0 = math.ceil((ts[0] - _SNAP * period_s) / period_s)
    k1 = math.floor((ts[-1] + _SNAP * period_s) / period_s)
    if periods is not None:
        k1 = min(k1, k0 + periods)
    if k1 - k0 < 2:
        raise ParameterError(
            "file",
            "",
            f"a run of >= 2 forcing periods after its first sample (it spans "
            f"{(ts[-1] - ts[0]) / period_s:.3g})",
        )
    tk = np.arange(k0, k1 + 1) * period_s
    return tk


def _at(ts: np.ndarray, ys: np.ndarray, tk: np.ndarray, period_s: float):
    """``ys`` at ``tk``: the last point at that time when one lies within ``_SNAP`` of it (a
    breakpoint), else linear interpolation; and how many were interpolated."""
    out = np.interp(tk, ts, ys)
    idx = np.clip(np.searchsorted(ts, tk, side="right") - 1, 0, len(ts) - 1)
    nxt = np.clip(idx + 1, 0, len(ts) - 1)
    snap = np.abs(ts[idx] - tk) <= _SNAP * period_s
    snap2 = ~snap & (np.abs(ts[nxt] - tk) <= _SNAP * period_s)
    out = np.where(snap, ys[idx], out)
    out = np.where(snap2, ys[nxt], out)
    return out, int(np.sum(~snap & ~snap2))


#: The range of ``periods`` scored (the one place: the CLI and :func:`score_netlist`).
MIN_PERIODS, MAX_PERIODS = 2, 10**6


def check_periods(value: Any) -> int:
    """``periods`` as an integer in ``MIN_PERIODS .. MAX_PERIODS`` (a score needs two forcing
    periods), or one line naming it."""
    return check_count(value, "periods", MAX_PERIODS, MIN_PERIODS)


def _node_map(
    map: str | Path | NodeMap | None,
    x_node: str | None,
    v_node: str | None,
    forcing_node: str | None,
    impact_node: str | None,
) -> NodeMap:
    """The node map: the ``map``'s (loaded if a path), overridden by the node names given."""
    nmap = map if isinstance(map, NodeMap) else (load_map(map) if map is not None else None)
    if nmap is None:
        if x_node is None or v_node is None:
            raise ParameterError(
                "x-node", x_node, "node names for x and v (--x-node, --v-node or --map)"
            )
        nmap = NodeMap(x=x_node, v=v_node)
    return dataclasses.replace(
        nmap,
        x=x_node or nmap.x,
        v=v_node or nmap.v,
        forcing=forcing_node or nmap.forcing,
        impact=impact_node or nmap.impact,
    )


def _netlist_runs(
    p: Path,
    nmap: NodeMap,
    step: int | None,
    workdir: str | Path | None,
    run_kw: dict,
) -> tuple[list[Waveforms], dict]:
    """Check a netlist's nodes and ``step``, run it by ngspice, keep the ``step``-th run."""
    text = read_netlist(p)
    roles = {"x": nmap.x, "v": nmap.v, "forcing": nmap.forcing, "impact": nmap.impact}
    check_nodes(text, roles, p.name)  # before ngspice runs
    n_tran = len(re.findall(r"^\s*\.tran\b", text, re.I | re.M))
    if step is not None and not re.search(r"^\s*\.step\b", text, re.I | re.M):
        if not 0 <= step < n_tran:
            raise ParameterError(
                "step", step, f"an integer 0 .. {n_tran - 1} ({p.name} has no .step)"
            )
    runs, info = run_netlist(p, workdir, **run_kw)
    if step is not None:
        if not 0 <= step < len(runs):
            raise ParameterError("step", step, f"an integer 0 .. {len(runs) - 1}")
        runs = [runs[step]]
    return runs, info


def _load_runs(
    p: Path,
    nmap: NodeMap,
    step: int | None,
    workdir: str | Path | None,
    run_kw: dict,
) -> tuple[list[Waveforms], dict, str]:
    """The runs of a ``.raw`` file (read) or of a netlist (run), their info and the kind."""
    suffix = p.suffix.lower()
    if suffix in RAW_SUFFIXES:
        return read_raw(p, step), {"options": {}, "notes": []}, "raw"
    if suffix in NETLIST_SUFFIXES:
        runs, info = _netlist_runs(p, nmap, step, workdir, run_kw)
        return runs, info, "netlist"
    _check_file(p, RAW_SUFFIXES + NETLIST_SUFFIXES, "netlist or raw file")
    raise AssertionError  # pragma: no cover


def _compression(
    runs: list[Waveforms], info: dict, kind: str, warnings: list[str], progress: bool | None
) -> dict:
    """LTspice compression of a raw file's runs (a warning when compressed)."""
    compression = (
        lt_compression(runs, info.get("options"))
        if kind == "raw"
        else {"compressed": False, "why": "run here by ngspice (no compression)"}
    )
    if compression.get("compressed"):
        warnings.append(compression["warning"])
        _progress("warning: " + compression["warning"], progress)
    return compression


def _map_runs(
    runs: list[Waveforms], nmap: NodeMap, params: Params, design: Any, scales: str
) -> list[tuple]:
    """Every run's corrected traces and mapping, checked before the reference is computed."""
    mapped = []
    for w in runs:
        vs = nmap.corrected("x", w.node(nmap.x, "x"))
        vq = nmap.corrected("v", w.node(nmap.v, "v"))
        aux = w.node(nmap.impact, "impact") if nmap.impact else None
        m, fit = _mapping(params, design, scales, w, nmap, vs, vq)
        mapped.append((w, vs, vq, aux, m, fit))
    return mapped


def _timing(
    mapped: list[tuple],
    params: Params,
    nmap: NodeMap,
    periods: int | None,
    transient: int | None,
    warnings: list[str],
) -> tuple[float, float, int, int]:
    """The forcing period in seconds, its phase, the periods scored and the transient."""
    m0, fit0 = mapped[0][4], mapped[0][5]
    eta = float(params.eta)
    period_s = 2 * math.pi / (m0["omega"] * eta)
    phase = (
        nmap.forcing_phase if nmap.forcing_phase is not None else (fit0["phase"] if fit0 else 0.0)
    )
    if fit0 is None and nmap.forcing_phase is None:
        warnings.append("no forcing node: the forcing is taken as cos(Omega t) from SPICE time 0")
    ts0 = mapped[0][0].time
    tk = _samples(ts0, period_s, ts0[0], periods)
    n_per = len(tk) - 1
    for w, *_ in mapped[1:]:
        n_per = min(n_per, len(_samples(w.time, period_s, w.time[0], periods)) - 1)
    k = n_per // 5 if transient is None else int(transient)
    if not 0 <= k < n_per:
        raise ParameterError("transient", transient, f"0 <= transient < periods ({n_per})")
    return period_s, phase, n_per, k


def _run_trajectory(
    run: tuple, params: Params, phase: float, period_s: float, n_per: int, elapsed_s: float
) -> tuple[Trajectory, np.ndarray, int]:
    """One run as a dimensionless trajectory sampled each period (its impacts detected);
    with the sample times in seconds and how many samples were interpolated."""
    w, vs, vq, aux, m, _fit = run
    eta = float(params.eta)
    tk = _samples(w.time, period_s, w.time[0], n_per)
    tk = tk[: n_per + 1]
    vs_k, n_i1 = _at(w.time, vs, tk, period_s)
    vq_k, n_i2 = _at(w.time, vq, tk, period_s)
    omega = m["omega"]
    t0_tau = phase / eta
    tau = omega * w.time + t0_tau
    x = vs / m["volts_per_x"]
    v = vq / m["volts_per_v"]
    x_k, v_k = vs_k / m["volts_per_x"], vq_k / m["volts_per_v"]
    tau_k = omega * tk + t0_tau
    p0 = params.replace(x0=float(x_k[0]), v0=float(v_k[0]), t0=float(tau_k[0]))
    tau_k = float(p0.t0) + np.arange(len(tk)) * (2 * math.pi / eta)
    ti, vb, va = impacts_from_waveform(tau, x, v, tau if aux is not None else None, aux)
    # only what lies between the first and the last sample is scored
    keep = (ti >= tau_k[0]) & (ti <= tau_k[-1])
    ti, vb, va = ti[keep], vb[keep], va[keep]
    inside = (w.time >= tk[0] - _SNAP * period_s) & (w.time <= tk[-1] + _SNAP * period_s)
    tau, x, v = tau[inside], x[inside], v[inside]
    tr = Trajectory(
        params=p0,
        model="spice",
        precision=Precision.parse("float64"),
        tol=None,
        t=tau_k,
        x=x_k,
        v=v_k,
        impacts_t=ti,
        impacts_v_before=vb,
        impacts_v_after=va,
        dense_t=tau,
        dense_x=x,
        dense_v=v,
        elapsed_s=elapsed_s,
        stats={"source": w.path},
    )
    return tr, tk, max(n_i1, n_i2)


def _score_run(
    tr: Trajectory, n_per: int, k: int, bits: int, lle: dict, progress: bool | None
) -> tuple[dict, Any, Any, dict, str]:
    """A run's scores against its own reference (from its first sample); the LLE (an
    attractor's) computed once into ``lle``."""
    p0 = tr.params
    ref, check, ref_info = demonstrated_reference(p0, n_per, 50, bits, progress)
    if not lle:
        lle.update(reference_lle(p0, progress))
    regime = "periodic" if detected_period(ref, k) > 0 else "chaotic"
    ref2 = None
    if regime == "chaotic":
        p2 = p0.replace(x0=p0.x0 + REF_PERTURBATION)
        ref2 = make_solver("heyoka", f"mp:{bits}").solve(p2, n_per)
    sc = score(tr, ref, regime=regime, lle=lle["lle"], ref2=ref2, transient=k)
    return sc, ref, check, ref_info, regime


def _score_runs(
    p: Path, mapped: list[tuple], params: Params, timing: tuple, info: dict, progress: bool | None
) -> tuple[list[dict], list[dict], dict]:
    """Every run's record, plot data and the LLE."""
    period_s, phase, n_per, k = timing
    bits = reference_bits(n_per)
    out_runs: list[dict] = []
    plots: list[dict] = []
    lle: dict = {}
    for run in mapped:
        w, m = run[0], run[4]
        elapsed = float(info.get("elapsed_s", 0.0))
        tr, tk, n_interp = _run_trajectory(run, params, phase, period_s, n_per, elapsed)
        sc, ref, check, ref_info, regime = _score_run(tr, n_per, k, bits, lle, progress)
        name = p.name if len(mapped) == 1 else f"{p.name} {w.label}"
        out_runs.append(
            {
                "name": name,
                "label": w.label,
                "points": int(len(w.time)),
                "periods": n_per,
                "first_sample_s": float(tk[0]),
                "initial_state": {
                    "x0": float(tr.x[0]),
                    "v0": float(tr.v[0]),
                    "t0": float(tr.params.t0),
                },
                "samples_interpolated": n_interp,
                "data_precision": w.precision,
                "regime": regime,
                "scores": sc,
                "mapping": m,
                "reference": ref_info,
            }
        )
        plots.append({"name": name, "ref": ref, "check": check, "traj": tr})
        _progress(f"{name}: " + score_line(sc), progress)
    return out_runs, plots, lle


def _ngspice_info(kind: str, info: dict) -> dict | None:
    """The ngspice run's mode, time, log and options (``None`` for a raw file)."""
    if kind == "raw":
        return None
    return {
        "ltspice_mode": info.get("ltspice_mode"),
        "elapsed_s": info.get("elapsed_s"),
        "log": info.get("ngspice_log"),
        "options": info.get("options"),
    }


def _write_outputs(res: NetlistScoreResult, out: str | Path, units: str) -> None:
    """``scores.json`` and each run's phase portraits and separation figures in ``out``."""
    o = Path(out)
    o.mkdir(parents=True, exist_ok=True)
    res.files = [str(o / "scores.json")]
    n = len(res._plots["runs"])
    for i in range(n):
        tag = "" if n == 1 else f"_{i}"
        for what, stem in (("portraits", "phase_portraits"), ("separation", "separation")):
            res.plot(o / f"{stem}{tag}.png", what, units, run=i)
            res.files.append(str(o / f"{stem}{tag}.png"))
    write_json(o / "scores.json", res.to_dict(), indent=2)


def score_netlist(
    path: str | Path,
    x_node: str | None = None,
    v_node: str | None = None,
    forcing_node: str | None = None,
    *,
    impact_node: str | None = None,
    map: str | Path | NodeMap | None = None,
    scene: str | None = None,
    scales: str = "auto",
    step: int | None = None,
    periods: int | None = None,
    transient: int | None = None,
    ltspice: bool | None = None,
    workdir: str | Path | None = None,
    out: str | Path | None = None,
    units: str = "dimensionless",
    timeout: float = 600,
    executable: str | None = None,
    progress: bool | None = None,
    max_time: float | None = None,
) -> NetlistScoreResult:
    """Score a user's SPICE netlist (run by ngspice) or raw waveform file against the
    demonstrated mechanical reference.

    Parameters
    ----------
    path : path
        A netlist (:data:`NETLIST_SUFFIXES`; LTspice ``.net`` run in ngspice's LTspice mode)
        or a ``.raw`` file (read, not run).
    x_node, v_node, forcing_node, impact_node : str or None
        Node names of ``V_s``, ``V_q``, ``V_3`` and an optional impact logic node; override
        the ``map``'s.
    map : path, NodeMap or None
        A TOML mapping (:func:`load_map`).
    scene : str or None
        The target scene (its parameters and design); else the map's.
    scales : {'auto', 'components', 'fitted'}
        Volts/seconds from the design values, or fitted to the waveform (needs the forcing
        node); ``'auto'``: the design's when there is one.
    step : int or None
        Only this run of a stepped/multi-plot file (0-based); ``None``: every one.
    periods, transient : int or None
        At most this many forcing periods scored, ``MIN_PERIODS .. MAX_PERIODS`` (default:
        all in the run); periods
        discarded before the scores (default ``periods // 5``).
    ltspice : bool or None
        See :func:`run_netlist`.
    workdir : path or None
        Keep ngspice's files here.
    out : directory or None
        Writes ``scores.json``, ``phase_portraits.png`` and ``separation.png``.
    units : {'dimensionless', 'circuit'}
        Axes of those figures.
    timeout : float, default 600
        Seconds ngspice may run.
    executable : str or None, default ``None``
        The ngspice program.
    progress : bool or None, default ``None``
        One line per finished step on stderr (``None``: only when stderr is a terminal).
    max_time : float or None, default ``None``
        Time budget of the ngspice run in seconds (see :func:`run_netlist`).

    Returns
    -------
    NetlistScoreResult
        Scores per run, the mapping with its uncertainties, the reference, the warnings.

    Raises
    ------
    ParameterError
        Bad input or a damaged, truncated, wrong-unit or wrong-node file: one line, before
        the reference is computed.
    SpiceError
        ngspice could not run the netlist.

    See Also
    --------
    precise_impact.verification.compare.compare : the same scores for the built-in models.
    precise_impact.verification.scores.score : the scores.
    precise_impact.lab.netlist.load_map : the TOML mapping.

    Notes
    -----
    Samples are taken at ``k T`` of SPICE time (``T = 2 pi / Omega``), from the first one
    inside the run: ngspice writes no point at t = 0 under ``uic``, so its runs start at
    ``t = T``.  Times on a breakpoint are read exactly, others linearly interpolated
    (``samples_interpolated``).  The reference starts from the first sample, mapped, at
    ``tau = omega t + phi / eta`` (``phi``: the forcing's fitted phase).

    Examples
    --------
    The project's own netlist, run as a user's file (ngspice):

    >>> import tempfile, pathlib
    >>> import precise_impact as pi
    >>> from precise_impact.lab.netlist import score_netlist
    >>> from precise_impact.models.circuit.spice import spice_netlist
    >>> sc = pi.load_scene("fig6-period3-ideal")
    >>> net = pathlib.Path(tempfile.mkdtemp()) / "mine.cir"
    >>> _ = net.write_text(spice_netlist(sc.design(), None, 11, 10e-6))
    >>> r = score_netlist(net, "s", "q", "v3", scene=sc.name, progress=False)
    >>> r.runs[0]["periods"], r.mapping["mode"], r.runs[0]["scores"]["initial_separation"] < 1e-15
    (10, 'components', True)
    """

    check_type(path, (str, os.PathLike), "path", "a netlist or .raw file (str or os.PathLike)")
    p = Path(path)
    nmap = _node_map(map, x_node, v_node, forcing_node, impact_node)
    if scales not in ("auto", "components", "fitted"):
        raise ParameterError("scales", scales, "'auto', 'components' or 'fitted'")
    if periods is not None:
        periods = check_periods(periods)
    if max_time is not None:
        max_time = parse_max_time(max_time)
    params, design, target = _target(nmap, scene)
    plot_units(units, components=design if units == "circuit" else None)  # before any work
    run_kw = {
        "ltspice": ltspice,
        "timeout": timeout,
        "executable": executable,
        "max_time": max_time,
    }
    runs, info, kind = _load_runs(p, nmap, step, workdir, run_kw)
    warnings: list[str] = list(info.get("notes", []))
    compression = _compression(runs, info, kind, warnings, progress)
    mapped = _map_runs(runs, nmap, params, design, scales)
    timing = _timing(mapped, params, nmap, periods, transient, warnings)
    out_runs, plots, lle = _score_runs(p, mapped, params, timing, info, progress)
    res = NetlistScoreResult(
        source=str(p),
        kind=kind,
        dialect=runs[0].dialect,
        params={**params.decimal(), "target": target},
        mapping=mapped[0][4],
        forcing=mapped[0][5],
        reference=out_runs[0]["reference"],
        lle=lle,
        runs=out_runs,
        compression=compression,
        warnings=warnings,
        ngspice=_ngspice_info(kind, info),
    )
    k = timing[3]
    res._plots = {"runs": plots, "k": k, "target": target, "params": params, "design": design}
    if out is not None:
        _write_outputs(res, out, units)
    return res


def format_result(res: NetlistScoreResult) -> str:
    """The text ``spice score`` prints.

    Parameters
    ----------
    res : NetlistScoreResult
        From :func:`score_netlist`.

    Returns
    -------
    str
        Source, mapping, reference, forcing fit, one line per run
        (:mod:`~precise_impact.verification.compare`'s form), the warnings.
    """

    m, r = res.mapping, res.reference
    scale = f"scales from {m['mode']}: omega = {m['omega']:.10g} rad/s"
    if m["mode"] == "fitted":
        scale += (
            f" +- {m['omega_stderr']:.2g}, V_unit = {m['V_unit']:.8g} +- "
            f"{m['V_unit_stderr']:.2g} V,"
            f" R8 C1 = {m['R8C1']:.8g} +- {m['R8C1_stderr']:.2g} s"
        )
    lines = [
        f"{res.source} ({res.kind}, {res.dialect}) against {res.params['target']}: "
        + ", ".join(
            f"{k} = {v}" for k, v in res.params.items() if k in ("zeta", "a", "eta", "x_w")
        ),
        scale,
        f"reference heyoka {r['precision']} agrees with {r['check_precision']} to "
        f"{r['agreement_max']:.1e}; LLE {res.lle['lle']:.4f} +- {res.lle['stderr']:.4f}",
    ]
    if res.forcing:
        f = res.forcing
        lines.append(
            f"forcing fit: Omega = {f['Omega']:.10g} +- {f['Omega_stderr']:.2g} rad/s, amplitude "
            f"{f['amplitude']:.8g} +- {f['amplitude_stderr']:.2g} V, phase {f['phase']:.3g} +- "
            f"{f['phase_stderr']:.2g} rad"
        )
    for run in res.runs:
        lines.append(
            f"  {run['label']:<20} {run['periods']} periods, {run['regime']}: "
            + score_line(run["scores"])
        )
    lines += [f"warning: {w}" for w in res.warnings]
    return "\n".join(lines)
