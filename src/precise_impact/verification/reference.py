"""Reference datasets for the paper's cases, with demonstrated accuracy and checksums.

Each case directory holds its data and a ``manifest.json`` (exact parameters, versions,
demonstrated accuracy, sha256), written last so a verified manifest means a complete case.
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import time
from collections.abc import Callable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.analysis.bifurcation import bifurcation
from precise_impact.analysis.lyapunov import lyapunov
from precise_impact.core.mpcontext import mp_context, mp_import
from precise_impact.core.params import Params, decimal_str
from precise_impact.core.precision import Precision, quad_or_mp
from precise_impact.errors import OptionalDependencyError, ParameterError
from precise_impact.io.atomic import atomic_write, sha256_file
from precise_impact.io.jsonout import write_json
from precise_impact.io.progress import say as _log
from precise_impact.solvers.heyoka.coupled import simulate_coupled
from precise_impact.solvers.simulate import simulate
from precise_impact.verification.certificate import add_certificate, check_certificate
from precise_impact.verification.manifest import (
    CERTIFICATE_FILE,
    FORMAT_VERSION,
    MANIFEST,
    read_manifest,
    write_manifest,
)
from precise_impact.verification.metrics import (
    DIGITS_LOST_PER_PERIOD,
    reference_bits,
    sample_errors,
)
from precise_impact.verification.proven_landmarks import check_landmarks, generate_landmarks

__all__ = [
    "CASES",
    "FORMAT_VERSION",
    "SINGLE_CASES",
    "REFERENCE_ENV",
    "default_root",
    "write_manifest",
    "checksum_problems",
    "shipped_root",
    "generate",
    "verify",
    "read_manifest",
]

#: The single-oscillator cases: case name -> eta (exact decimal).
SINGLE_CASES = {"single-0.70": "0.70", "single-0.712": "0.712", "single-0.74": "0.74"}
SINGLE_PERIODS = 300
DENSE_PER_PERIOD = 50
DENSE_LAST_PERIODS = 50

COUPLED_KS = ("0.031", "0.032")
COUPLED_PERIODS = 500
COUPLED_Y0 = ("-1/2", "1/2")
COUPLED_AGREE = 1e-6  # float64 vs float128 agreement that counts as "demonstrated"

LLE_ETAS = ("0.70", "0.712", "0.74")
LLE_PERIODS = 20000
LLE_TRANSIENT = 1000

BIF_RANGE = ("0.68", "0.82", 141)
BIF_PERIODS = 500
BIF_TRANSIENT = 500
BIF_KEEP_X = 8

#: Periods recomputed by :func:`verify` for each single case (float128).
VERIFY_PERIODS = 20


#: Environment variable naming a dataset directory that replaces the shipped one everywhere.
REFERENCE_ENV = "PRECISE_IMPACT_REFERENCE"


def shipped_root() -> Path:
    """The shipped datasets: ``precise_impact/data/reference`` in the installed package.

    The repository keeps one copy, at its top level (``reference_data/``), which the wheel
    installs as that package directory; an editable checkout reads it in place.
    """
    packaged = Path(str(resources.files("precise_impact") / "data" / "reference"))
    if packaged.is_dir():
        return packaged
    checkout = Path(__file__).resolve().parents[3] / "reference_data"
    return checkout if checkout.is_dir() else packaged


def default_root() -> Path:
    """Where datasets are read from: ``$PRECISE_IMPACT_REFERENCE`` if set, else
    :func:`shipped_root`.

    Every entry point (the ``testing`` API, ``reference verify``, ``compare``) resolves
    its default through this one function, so the override is honoured everywhere.
    """
    env = os.environ.get(REFERENCE_ENV)
    return Path(env) if env else shipped_root()


# ------------------------------------------------------------------ helpers
_sha256 = sha256_file


_write_json = write_json


def _write_npz(path: Path, **arrays: np.ndarray) -> None:
    atomic_write(path, lambda fh: np.savez_compressed(fh, **arrays), binary=True)


def checksum_problems(case_dir: Path, case: str) -> list[str]:
    """Problems of one dataset directory against its manifest: missing files, changed checksums.

    Returns
    -------
    list of str
        One line per problem, each naming the case and the file; empty if intact.
    """
    mpath = case_dir / MANIFEST
    if not mpath.is_file():
        return [f"{case}: missing {MANIFEST}"]
    try:
        manifest = read_manifest(case_dir)
    except (OSError, ValueError) as e:
        return [f"{case}: unreadable {MANIFEST}: {e}"]
    files = manifest.get("files")
    if not isinstance(files, dict) or not files:
        return [f"{case}: {MANIFEST} lists no data files"]
    problems = []
    for name, info in files.items():
        p = case_dir / name
        if not p.is_file():
            problems.append(f"{case}: missing data file {name}")
        elif _sha256(p) != info.get("sha256"):
            problems.append(f"{case}: checksum mismatch for {name} (file changed since generation)")
    return problems


# ------------------------------------------------------------------ single cases
def _impact_dicts(traj) -> list[dict]:
    s = traj.precision.to_str
    return [
        {"t": s(t), "v_before": s(vb), "v_after": s(va)}
        for t, vb, va in zip(
            traj.impacts_t, traj.impacts_v_before, traj.impacts_v_after, strict=True
        )
    ]


def _impact_disagreement(a, b) -> float | None:
    if a.n_impacts != b.n_impacts:
        return None
    ctx = mp_context(max(a.precision.bits, b.precision.bits) + 16)  # not the shared global one
    worst = ctx.mpf(0)
    for (t1, b1, a1), (t2, b2, a2) in zip(a.impacts_mpf(), b.impacts_mpf(), strict=True):
        t1, b1, a1 = (mp_import(ctx, z) for z in (t1, b1, a1))
        worst = max(worst, abs(t1 - t2), abs(b1 - b2), abs(a1 - a2))
    return float(worst)


def _single_samples(case: str, params: Params, P: Precision, ref: Any, errs: list) -> dict:
    """The ``samples.json`` document of a single-oscillator case: the stored decimals."""
    s = P.to_str
    samples = {
        "case": case,
        "params": params.decimal(),
        "model": "heyoka",
        "precision": P.name,
        "digits": P.digits,
        "periods": SINGLE_PERIODS,
        "sample_times": (
            "t0 + k 2 pi / eta, k = 0..periods (each correctly rounded to the precision)"
        ),
        "samples": [
            {"period": k, "t": s(t), "x": s(x), "v": s(v)}
            for k, (t, x, v) in enumerate(zip(ref.t, ref.x, ref.v, strict=True))
        ],
        "impacts": _impact_dicts(ref),
        # disagreement with the +64-bit run at each sample: the demonstrated error bound
        "sample_disagreement": [f"{e:.3e}" for e in errs],
    }
    return samples


def _single_manifest(
    case: str, eta: str, params: Params, P: Precision, bits: int, ref: Any, errs: list, imp_dis: Any
) -> dict:
    """The manifest metadata of a single-oscillator case: provenance and accuracy."""
    return {
        "case": case,
        "description": (
            f"single impact oscillator from rest, eta = {eta}, {SINGLE_PERIODS} periods"
        ),
        "params": params.decimal(),
        "model": "heyoka (Taylor integrator with impact events)",
        "precision": P.name,
        "tolerance": f"machine epsilon of {P.name} (2**-{bits - 1})",
        "periods": SINGLE_PERIODS,
        "impacts": ref.n_impacts,
        "accuracy": {
            "method": (
                f"two heyoka runs, {P.name} (stored) and mp:{bits + 64}, compared at every "
                "stroboscopic sample"
            ),
            "runs": [P.name, f"mp:{bits + 64}"],
            "max_sample_disagreement": f"{max(errs):.3e}",
            "final_sample_disagreement": f"{errs[-1]:.3e}",
            "max_impact_disagreement": None if imp_dis is None else f"{imp_dis:.3e}",
            "impact_counts_agree": imp_dis is not None,
            "metric": "max(|x - x'|, |v - v'|)",
        },
        "dense": {
            "file": "dense.npz",
            "precision": "float64 (heyoka float64 run; for plotting only, NOT the reference)",
            "per_period": DENSE_PER_PERIOD,
            "periods": f"last {DENSE_LAST_PERIODS} of {SINGLE_PERIODS}",
            "note": "strobe_* / impacts_t arrays are the mp reference rounded to float64",
        },
    }


def _gen_single(case: str, case_dir: Path, progress: bool) -> dict:
    eta = SINGLE_CASES[case]
    params = Params.make(eta=eta)
    bits = reference_bits(SINGLE_PERIODS)
    P = Precision.parse(f"mp:{bits}")
    t0 = time.perf_counter()
    ref = simulate(params, SINGLE_PERIODS, precision=P)
    check = simulate(params, SINGLE_PERIODS, precision=f"mp:{bits + 64}")
    errs = sample_errors(ref, check)
    imp_dis = _impact_disagreement(ref, check)
    _log(
        f"  {case}: mp:{bits} vs mp:{bits + 64}: max {max(errs):.2e} "
        f"({time.perf_counter() - t0:.1f} s)",
        progress,
    )
    samples = _single_samples(case, params, P, ref, errs)
    _write_json(case_dir / "samples.json", samples)
    dense = simulate(params, SINGLE_PERIODS, precision="float64", per_period=DENSE_PER_PERIOD)
    n0 = (SINGLE_PERIODS - DENSE_LAST_PERIODS) * DENSE_PER_PERIOD
    f64 = ref.as_float64()
    _write_npz(
        case_dir / "dense.npz",
        dense_t=np.asarray(dense.dense_t[n0:], dtype=float),
        dense_x=np.asarray(dense.dense_x[n0:], dtype=float),
        dense_v=np.asarray(dense.dense_v[n0:], dtype=float),
        strobe_t=f64["t"],
        strobe_x=f64["x"],
        strobe_v=f64["v"],
        impacts_t=f64["impacts_t"],
    )
    write_manifest(
        case_dir,
        ["samples.json", "dense.npz"],
        _single_manifest(case, eta, params, P, bits, ref, errs, imp_dis),
    )

    _log(f"  {case}: certifying (proven error bounds of the stored decimals)", progress)
    return add_certificate(case_dir)


# ------------------------------------------------------------------ coupled
def _gen_coupled(case: str, case_dir: Path, progress: bool) -> dict:

    params = Params.make()
    arrays: dict[str, np.ndarray] = {}
    acc: dict[str, Any] = {}
    for k in COUPLED_KS:
        a = simulate_coupled(
            params, k, "first-order", COUPLED_PERIODS, y0=COUPLED_Y0, precision="float64"
        )
        b = simulate_coupled(
            params, k, "first-order", COUPLED_PERIODS, y0=COUPLED_Y0, precision="float128"
        )
        tag = k.replace(".", "p")
        xa, ya = a._f(a.x), a._f(a.y)
        _, d = a.difference()
        arrays[f"t_k{tag}"] = a._f(a.t)
        arrays[f"x_k{tag}"] = xa
        arrays[f"y_k{tag}"] = ya
        arrays[f"absdiff_k{tag}"] = d
        xb, yb = b._f(b.x), b._f(b.y)
        dev = np.maximum(np.abs(xa - xb), np.abs(ya - yb))
        bad = np.nonzero(dev > COUPLED_AGREE)[0]
        n_ok = int(bad[0]) - 1 if len(bad) else COUPLED_PERIODS
        arrays[f"f64_vs_f128_k{tag}"] = dev
        acc[k] = {
            "periods_agreeing_to_1e-6": n_ok,
            "max_disagreement_first_20_periods": f"{dev[:21].max():.3e}",
            "max_disagreement_all_periods": f"{dev.max():.3e}",
            "final_absdiff_float64": f"{d[-1]:.3e}",
            "final_absdiff_float128": f"{abs(b._f(b.x - b.y))[-1]:.3e}",
        }
        _log(f"  {case}: k={k}: float64 and float128 agree to 1e-6 for {n_ok} periods", progress)
    _write_npz(case_dir / "coupled.npz", **arrays)
    return write_manifest(
        case_dir,
        ["coupled.npz"],
        {
            "case": case,
            "description": (
                "master-slave pair (eqs. 11-12, first-order form), Fig. 7: k = 0.031 and 0.032"
            ),
            "params": params.decimal(),
            "k": list(COUPLED_KS),
            "y0": list(COUPLED_Y0),
            "form": "first-order",
            "model": "heyoka (coupled integrator with impact events)",
            "precision": "float64",
            "tolerance": "machine epsilon of float64",
            "periods": COUPLED_PERIODS,
            "accuracy": {
                "method": (
                    "the same runs in float64 (stored) and float128, compared at every "
                    "stroboscopic sample"
                ),
                "runs": ["float64", "float128"],
                "per_k": acc,
                "what_is_demonstrated": (
                    "The float64 samples are pointwise accurate (to 1e-6) only over the periods "
                    "listed in periods_agreeing_to_1e-6; the master is chaotic, so later samples "
                    "are one valid realisation, not the exact orbit.  The synchronisation outcome "
                    "(|x - y| decay or not) is a statistical property and is compared via "
                    "final_absdiff in both precisions."
                ),
            },
        },
    )


# ------------------------------------------------------------------ lle
def _gen_lle(case: str, case_dir: Path, progress: bool) -> dict:

    rows = []
    for eta in LLE_ETAS:
        p = Params.make(eta=eta)
        var = lyapunov(p, "variational", periods=LLE_PERIODS, transient=LLE_TRANSIENT)
        two = lyapunov(p, "two-trajectory", periods=LLE_PERIODS, transient=LLE_TRANSIENT)
        diff = abs(var.lle - two.lle)
        comb = math.hypot(var.lle_stderr, two.lle_stderr)
        rows.append(
            {
                "eta": eta,
                "variational": {
                    "lle": repr(float(var.lle)),
                    "stderr": repr(float(var.lle_stderr)),
                    "spectrum": [repr(float(s)) for s in var.spectrum] if var.spectrum else None,
                    "impacts": int(var.n_impacts),
                    "initial_conditions": int(var.initial_conditions),
                },
                "two_trajectory": {
                    "lle": repr(float(two.lle)),
                    "stderr": repr(float(two.lle_stderr)),
                    "impacts": int(two.n_impacts),
                },
                "difference": f"{diff:.3e}",
                "combined_stderr": f"{comb:.3e}",
                "methods_agree_within_3_sigma": bool(diff <= 3 * comb + 1e-12),
            }
        )
        _log(
            f"  {case}: eta={eta}: {var.lle:.5f} +- {var.lle_stderr:.5f} "
            f"(two-traj {two.lle:.5f} +- {two.lle_stderr:.5f})",
            progress,
        )
    _write_json(
        case_dir / "lle.json", {"case": case, "units": "per unit dimensionless time", "rows": rows}
    )
    return write_manifest(
        case_dir,
        ["lle.json"],
        {
            "case": case,
            "description": "largest Lyapunov exponent at the paper's three frequencies",
            "params": Params.make().decimal() | {"eta": list(LLE_ETAS)},
            "model": (
                "heyoka variational equations + saltation (QR each period); Benettin two-trajectory"
            ),
            "precision": "float64",
            "tolerance": "machine epsilon of float64",
            "periods": LLE_PERIODS,
            "transient": LLE_TRANSIENT,
            "accuracy": {
                "method": "two independent methods; error bars by batch means (20 segments)",
                "runs": ["variational", "two-trajectory"],
                "agree_within_3_sigma": {r["eta"]: r["methods_agree_within_3_sigma"] for r in rows},
                "what_is_demonstrated": (
                    "statistical agreement of two methods, not digits of a single orbit"
                ),
            },
        },
    )


# ------------------------------------------------------------------ bifurcation
def _gen_bifurcation(case: str, case_dir: Path, progress: bool) -> dict:

    params = Params.make()
    lo, hi, n = BIF_RANGE
    r = bifurcation(
        params, ("eta", lo, hi, n), periods=BIF_PERIODS, transient=BIF_TRANSIENT, progress=progress
    )
    _write_npz(
        case_dir / "bifurcation.npz",
        eta_str=np.array([decimal_str(e) for e in r.eta]),
        eta=np.array([float(e) for e in r.eta]),
        lle=np.asarray(r.lle, dtype=float),
        lle_stderr=np.asarray(r.lle_stderr, dtype=float),
        impacts_per_period=np.asarray(r.impacts_per_period, dtype=float),
        strobe_x_last=np.asarray(r.x, dtype=float)[:, -BIF_KEEP_X:],
        grazing=np.asarray(r.grazing, dtype=float),
    )
    return write_manifest(
        case_dir,
        ["bifurcation.npz"],
        {
            "case": case,
            "description": f"bifurcation table over eta in [{lo}, {hi}], {n} exact values",
            "params": params.decimal() | {"eta": {"min": lo, "max": hi, "n": n}},
            "model": "heyoka variational equations (one orbit from rest per eta, 10 segments)",
            "precision": "float64",
            "tolerance": "machine epsilon of float64",
            "periods": BIF_PERIODS,
            "transient": BIF_TRANSIENT,
            "columns": {
                "eta_str": "exact decimal eta",
                "lle": "largest Lyapunov exponent per unit time",
                "lle_stderr": "batch-means standard error",
                "impacts_per_period": "impacts / measured periods",
                "strobe_x_last": f"last {BIF_KEEP_X} stroboscopic x values (float64)",
            },
            "accuracy": {
                "method": "none beyond the error bars: statistical quantities of float64 runs",
                "runs": ["float64"],
                "what_is_demonstrated": (
                    "LLE error bars (batch means); stroboscopic x values in chaotic windows are "
                    "one realisation on the attractor, not a precise orbit"
                ),
            },
        },
    )


def _gen_landmarks(case: str, case_dir: Path, progress: bool) -> dict:

    return generate_landmarks(case, case_dir, progress)


#: Every case and its generator.
CASES: dict[str, Callable[[str, Path, bool], dict]] = {
    **{name: _gen_single for name in SINGLE_CASES},
    "coupled-fig7": _gen_coupled,
    "lle": _gen_lle,
    "bifurcation": _gen_bifurcation,
    "landmarks": _gen_landmarks,
}


def _check_cases(cases: Sequence[str] | str | None) -> list[str]:
    if cases is None:
        return list(CASES)
    if isinstance(cases, str):
        cases = [cases]
    out = []
    for c in cases:
        if c not in CASES:
            raise ParameterError("case", c, "one of " + ", ".join(CASES))
        if c not in out:
            out.append(c)
    return out


def generate(
    cases: Sequence[str] | str | None = None,
    out: str | Path = Path("reference_data"),
    progress: bool | None = None,
    force: bool = False,
) -> dict[str, dict]:
    """Generate reference datasets into ``out/<case>/``.

    Parameters
    ----------
    cases : None, str or list of str, default ``None``
        A case name or a list of names; ``None`` is every case in :data:`CASES`.
    out : directory, default ``'reference_data'``
        Where the case directories are written.
    progress : bool or None, default ``None``
        One line per step on stderr (``None``: only when stderr is a terminal).
    force : bool, default ``False``
        Regenerate even cases whose manifest exists and whose checksums verify
        (otherwise those are skipped: resume after an interruption).

    Returns
    -------
    dict
        ``{case: manifest}`` (the existing manifest for skipped cases, with
        ``"skipped": True`` added).  Every file is written atomically, the manifest last.

    See Also
    --------
    precise_impact.verification.reference.verify : check the datasets written.
    precise_impact.solvers.certified.single.certify
        A certified trajectory, independent of the datasets.
    precise_impact.verification.reproduce.reproduce : the paper's figures from the same cases.

    Examples
    --------
    >>> import precise_impact as pi
    >>> from precise_impact.verification.reference import CASES
    >>> sorted(CASES)[:4]    # the case names accepted (the rest: single-0.70, -0.712, -0.74)
    ['bifurcation', 'coupled-fig7', 'landmarks', 'lle']
    """
    names = _check_cases(cases)
    out = Path(out)
    result: dict[str, dict] = {}
    import heyoka  # noqa: PLC0415 -- heavy: heyoka, loaded when a case is generated

    heyoka.set_logger_level_error()
    for case in names:
        case_dir = out / case
        if not force and (case_dir / MANIFEST).is_file() and not checksum_problems(case_dir, case):
            m = read_manifest(case_dir)
            m["skipped"] = True
            result[case] = m
            _log(f"{case}: up to date (manifest and checksums verify), skipped", progress)
            continue
        _log(f"{case}: generating", progress)
        t0 = time.perf_counter()
        case_dir.mkdir(parents=True, exist_ok=True)
        stale = case_dir / MANIFEST
        if stale.exists():
            stale.unlink()  # an incomplete or stale case must not look complete mid-way
        result[case] = CASES[case](case, case_dir, progress)
        _log(f"{case}: done ({time.perf_counter() - t0:.1f} s)", progress)
    return result


# ------------------------------------------------------------------ verify
def single_tolerance(period: int, precision: Precision, stored_disagreement: float = 0.0) -> float:
    """Allowed |recomputed - stored| at ``period`` for a recomputation in ``precision``.

    ``1e4 eps`` at the start, growing by 1.5x the measured chaotic loss rate
    (:data:`~precise_impact.verification.accuracy.DIGITS_LOST_PER_PERIOD` decimal digits per
    period), plus the stored reference's own demonstrated disagreement.
    """
    return (
        1e4 * precision.eps_float * 10 ** (1.5 * DIGITS_LOST_PER_PERIOD * period)
        + stored_disagreement
    )


def _recompute_single(case: str, case_dir: Path) -> list[str]:
    with open(case_dir / "samples.json") as fh:
        data = json.load(fh)
    params = Params.make(**data["params"])
    P = Precision.parse(quad_or_mp())
    n = min(VERIFY_PERIODS, data["periods"])
    traj = simulate(params, n, precision=P)
    manifest = read_manifest(case_dir)
    stored = float(manifest["accuracy"]["max_sample_disagreement"])
    problems = []
    mp = mp_context(400)  # this thread's own context: the global precision is shared
    for k in range(n + 1):
        row = data["samples"][k]
        _, x, v = traj.state_mpf(k)
        err = float(max(abs(mp.mpf(row["x"]) - x), abs(mp.mpf(row["v"]) - v)))
        tol = single_tolerance(k, P, stored)
        if not err <= tol:
            problems.append(
                f"{case}: recomputed float128 sample at period {k} differs from stored by "
                f"{err:.3e} > {tol:.3e}"
            )
            break
    t_end = traj.t[-1]
    t_end = P.to_mpf(t_end)
    stored_imp = [i for i in data["impacts"] if mp.mpf(i["t"]) < t_end]
    if len(stored_imp) != traj.n_impacts:
        problems.append(
            f"{case}: {traj.n_impacts} impacts recomputed in the first {n} periods, "
            f"{len(stored_imp)} stored"
        )
    else:
        for j, ((t, _vb, va), row) in enumerate(zip(traj.impacts_mpf(), stored_imp, strict=True)):
            err = float(max(abs(mp.mpf(row["t"]) - t), abs(mp.mpf(row["v_after"]) - va)))
            # impact times are ill-conditioned near grazing: 1e3 x the sample tolerance
            tol = 1e3 * single_tolerance(n, P, stored)
            if not err <= tol:
                problems.append(f"{case}: impact {j} differs from stored by {err:.3e} > {tol:.3e}")
                break
    return problems


def _recompute_coupled(case: str, case_dir: Path) -> list[str]:

    n = VERIFY_PERIODS
    problems = []
    with np.load(case_dir / "coupled.npz") as z:
        for k in COUPLED_KS:
            tag = k.replace(".", "p")
            tr = simulate_coupled(
                Params.make(), k, "first-order", n, y0=COUPLED_Y0, precision=quad_or_mp()
            )
            dev = max(
                float(np.max(np.abs(tr._f(tr.x) - z[f"x_k{tag}"][: n + 1]))),
                float(np.max(np.abs(tr._f(tr.y) - z[f"y_k{tag}"][: n + 1]))),
            )
            if not dev <= 1e-9:
                problems.append(
                    f"{case}: k={k}: recomputed first {n} periods differ from stored by "
                    f"{dev:.3e} > 1e-9"
                )
    return problems


def _sanity(case: str, case_dir: Path) -> list[str]:
    problems = []
    if case == "lle":
        with open(case_dir / "lle.json") as fh:
            rows = json.load(fh)["rows"]
        if [r["eta"] for r in rows] != list(LLE_ETAS):
            problems.append(f"{case}: rows are not eta = {', '.join(LLE_ETAS)}")
        for r in rows:
            if not all(
                math.isfinite(float(r[m]["lle"])) for m in ("variational", "two_trajectory")
            ):
                problems.append(f"{case}: non-finite LLE at eta = {r['eta']}")
    elif case == "bifurcation":
        with np.load(case_dir / "bifurcation.npz") as z:
            if len(z["eta"]) != BIF_RANGE[2] or not np.all(np.isfinite(z["lle"])):
                problems.append(f"{case}: table has the wrong size or non-finite LLE values")
    return problems


def verify(
    root: str | Path | None = None, cases: Sequence[str] | str | None = None, recompute: bool = True
) -> list[str]:
    """Check the datasets under ``root``; return a list of problems (empty = ok).

    Parameters
    ----------
    root : directory or None, default ``None``
        Datasets to check; ``None`` is :func:`default_root`.
    cases : None, str or list of str, default ``None``
        A case name or a list; ``None`` is every case in :data:`CASES` (a missing
        case is a problem).
    recompute : bool, default ``True``
        Besides the checksums, recompute a cheap subset: the first
        :data:`VERIFY_PERIODS` periods of each single case in float128 (compared to
        the stored decimals within :func:`single_tolerance`) and of each coupled run
        (within 1e-9); the proven landmarks re-proven; sanity checks on the LLE and
        bifurcation tables.

    Returns
    -------
    list of str
        One message per problem (missing file, checksum mismatch, recomputed
        value outside its tolerance); empty when every dataset verifies.

    See Also
    --------
    precise_impact.verification.reference.generate : write the datasets checked.
    precise_impact.errors.ReferenceDataError : raised when shipped data is unusable.
    precise_impact.verification.reproduce.reproduce : the paper's figures.

    Examples
    --------
    >>> import precise_impact as pi
    >>> pi.verify_reference(recompute=False)    # checksums of the shipped data: no problems
    []
    """
    root = default_root() if root is None else Path(root)
    problems: list[str] = []
    if importlib.util.find_spec("flint") is None:  # the proofs need python-flint (a dependency)
        raise OptionalDependencyError(
            "python-flint", "re-checking the references' proofs", "pip install python-flint"
        )
    for case in _check_cases(cases):
        case_dir = root / case
        p = checksum_problems(case_dir, case)
        problems += p
        if p or not recompute:
            continue
        try:
            if case in SINGLE_CASES:
                problems += _recompute_single(case, case_dir)
                if CERTIFICATE_FILE in read_manifest(case_dir)["files"]:
                    problems += check_certificate(case, case_dir)
            elif case == "coupled-fig7":
                problems += _recompute_coupled(case, case_dir)
            elif case == "landmarks":  # the proven intervals, re-proven
                problems += check_landmarks(case, case_dir)
            else:
                problems += _sanity(case, case_dir)
        except Exception as e:  # a malformed file that still matches its checksum
            problems.append(f"{case}: recomputation failed: {type(e).__name__}: {e}")
    return problems
