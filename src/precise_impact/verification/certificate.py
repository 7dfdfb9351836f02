"""Proofs for the shipped single-oscillator references: a ``certificate.json`` beside each case.

A proven bound ``|y - truth|`` for every stored decimal, re-proven by ``reference verify``.
"""

from __future__ import annotations

import datetime as _dt
import json
import time
from decimal import ROUND_CEILING, Decimal, localcontext
from fractions import Fraction
from pathlib import Path

__all__ = [
    "CERTIFICATE",
    "CERTIFICATE_BITS",
    "certificate_for",
    "add_certificate",
    "check_certificate",
]

from precise_impact.core.params import Params
from precise_impact.io.atomic import sha256_file as _sha256
from precise_impact.io.jsonout import write_json
from precise_impact.solvers.certified.single import certify, exact_value
from precise_impact.verification.manifest import CERTIFICATE_FILE as CERTIFICATE  # noqa: E402
from precise_impact.verification.manifest import MANIFEST, _versions, read_manifest

#: Working precision of the certificates: radii ~1e-70 after 300 chaotic periods, far below the
#: references' own errors (1e-54 at eta = 0.712), in ~0.3 s per case.
CERTIFICATE_BITS = 512


def _up(q: Fraction) -> str:
    with localcontext() as ctx:
        ctx.prec = 3
        ctx.rounding = ROUND_CEILING
        return str(Decimal(q.numerator) / Decimal(q.denominator)).replace("E", "e")


def _err(stored: str, ball) -> Fraction:
    """``|stored - mid| + rad`` exactly (an upper bound of ``|stored - truth|``)."""

    return abs(Fraction(stored) - exact_value(ball.mid())) + exact_value(ball.rad())


def certificate_for(samples_json: dict, bits: int = CERTIFICATE_BITS) -> dict:
    """The certificate of a single-oscillator reference (the parsed ``samples.json``).

    Parameters
    ----------
    samples_json : dict
        The case's stored samples and impacts (``params``, ``periods``, ``samples``, ``impacts``).
    bits : int, default :data:`CERTIFICATE_BITS`
        Working precision of the certified run.

    Returns
    -------
    dict
        ``{"method", "bits", "periods", "impacts", "samples": [{"period", "x_err", "v_err"}],
        "impact_errors": [{"t_err", "v_err"}], "max_err", "elapsed_s"}``.

    Raises
    ------
    ValueError
        The certified run's impact count differs from the stored one (the reference is wrong).
    """

    t0 = time.perf_counter()
    p = Params.make(**samples_json["params"])
    # the scheme the shipped certificates were made with (reproducible bounds)
    r = certify(
        p, samples_json["periods"], precision=f"mp:{bits}", max_bits=bits, method="interval"
    )
    if len(r.impacts) != len(samples_json["impacts"]):
        raise ValueError(
            f"the certified run has {len(r.impacts)} impacts, the reference "
            f"{len(samples_json['impacts'])}"
        )
    rows, worst = [], Fraction(0)
    for s in samples_json["samples"]:
        _, _, bx, bv = r.samples[s["period"]]
        ex, ev = _err(s["x"], bx), _err(s["v"], bv)
        worst = max(worst, ex, ev)
        rows.append({"period": s["period"], "x_err": _up(ex), "v_err": _up(ev)})
    imps = []
    for row, (bt, _, va) in zip(samples_json["impacts"], r.impacts, strict=True):
        et, ev = _err(row["t"], bt), _err(row["v_after"], va)
        imps.append({"t_err": _up(et), "v_err": _up(ev)})
    return {
        "method": (
            "certified engine (python-flint arb, closed-form flights, isolated impacts, interval "
            "Newton); err = |stored - mid| + rad, rounded up: a proven bound of |stored - truth|"
        ),
        "bits": bits,
        "periods": samples_json["periods"],
        "impacts": len(r.impacts),
        "samples": rows,
        "impact_errors": imps,
        "max_err": _up(worst),
        "elapsed_s": time.perf_counter() - t0,
    }


def add_certificate(case_dir: str | Path, bits: int = CERTIFICATE_BITS) -> dict:
    """Write ``certificate.json`` into a single case and list it in the manifest (checksummed; the
    manifest keeps its generation record and gains ``"proof"``).

    Parameters
    ----------
    case_dir : path
        The case directory (``samples.json`` and ``manifest.json``).
    bits : int, default :data:`CERTIFICATE_BITS`
        Working precision.

    Returns
    -------
    dict
        The updated manifest.
    """
    case_dir = Path(case_dir)
    data = json.loads((case_dir / "samples.json").read_text())
    cert = certificate_for(data, bits)
    write_json(case_dir / CERTIFICATE, cert)
    m = read_manifest(case_dir)
    m["files"][CERTIFICATE] = {
        "sha256": _sha256(case_dir / CERTIFICATE),
        "bytes": (case_dir / CERTIFICATE).stat().st_size,
    }
    m["proof"] = {
        "file": CERTIFICATE,
        "bits": bits,
        "max_proven_error": cert["max_err"],
        "method": (
            "every stored sample and impact within a proven bound of the truth (ball arithmetic)"
        ),
        "versions": _versions(),
        "generated_utc": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
    }
    write_json(case_dir / MANIFEST, m)
    return m


def check_certificate(case: str, case_dir: str | Path) -> list[str]:
    """Re-check a case's certificate on this machine: a fresh certified run at the stored bits;
    every stored decimal ``y`` must have the fresh ball inside ``[y - err, y + err]``.

    Parameters
    ----------
    case : str
        The case name (for the messages).
    case_dir : path
        The case directory.

    Returns
    -------
    list of str
        Problems (empty: every stored bound holds).
    """

    case_dir = Path(case_dir)
    data = json.loads((case_dir / "samples.json").read_text())
    cert = json.loads((case_dir / CERTIFICATE).read_text())
    r = certify(
        Params.make(**data["params"]),
        data["periods"],
        precision=f"mp:{cert['bits']}",
        max_bits=cert["bits"],
        method="interval",
    )
    if len(r.impacts) != cert["impacts"] or len(r.impacts) != len(data["impacts"]):
        return [
            f"{case}: the certified run has {len(r.impacts)} impacts, the certificate "
            f"{cert['impacts']}"
        ]
    for s, c in zip(data["samples"], cert["samples"], strict=True):
        _, _, bx, bv = r.samples[s["period"]]
        for name, ball in (("x", bx), ("v", bv)):
            if _err(s[name], ball) > Fraction(c[f"{name}_err"]):
                return [
                    f"{case}: stored {name} at period {s['period']} is not within its proven bound "
                    f"{c[name + '_err']} of the freshly certified ball"
                ]
    for j, (row, c, (bt, _, va)) in enumerate(
        zip(data["impacts"], cert["impact_errors"], r.impacts, strict=True)
    ):
        if _err(row["t"], bt) > Fraction(c["t_err"]) or _err(row["v_after"], va) > Fraction(
            c["v_err"]
        ):
            return [
                f"{case}: stored impact {j} is not within its proven bound of the freshly "
                "certified ball"
            ]
    return []
