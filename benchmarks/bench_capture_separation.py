"""The false-positive rate of ``score_capture``'s "separated" verdict (issue 24, review item 6).

Run:  python benchmarks/bench_capture_separation.py [--seeds N] [--out DIR]

An ideal capture scored against the ideal model is never "off the model": every record whose
ratio ``SW / sw_floor_max`` (the section distance over the largest floor) exceeds the threshold
is a false positive.  For each condition (the default measurement -- 8 bits, 1 % white noise,
200 periods, 20 kSa/s -- at eta = 0.74 (period 3) and 0.712 (chaotic); and 4 bits at 0.74) and
each seed, an independent capture (``seed``) is scored against independent model captures
(``seed=10000 + seed``).  Writes ``capture_separation.{json,md}`` (default
``benchmarks/results/``): each condition's ratios, their quantiles and maximum, and the
datasheet switched-capacitor capture's ratio (the separation the threshold must keep).
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

from precise_impact.io.atomic import atomic_write
from precise_impact.io.jsonout import write_json
from precise_impact.io.markdown import table
from precise_impact.lab.attractor import score_capture
from precise_impact.lab.synth import synth_capture

OUT = Path(__file__).resolve().parent / "results"
CONDITIONS = {
    "8 bit, eta 0.74": {"eta": "0.74", "bits": 8},
    "8 bit, eta 0.712": {"eta": "0.712", "bits": 8},
    "4 bit, eta 0.74": {"eta": "0.74", "bits": 4},
}


def ratio(scene: str, eta: str, bits: int, seed: int) -> dict:
    cap = synth_capture(scene, eta=eta, bits=bits, noise=0.01, periods=200, seed=seed)
    s = score_capture(cap, "fig6-period3-ideal", eta=eta, seed=10000 + seed, lle=False)
    return {
        "seed": seed,
        "ratio": s.sliced_wasserstein / s.sw_floor_max,
        "sw": s.sliced_wasserstein,
        "floor_max": s.sw_floor_max,
        "floor_halves": s.sw_floor_halves,
        "notes": list(s.notes),
        "separated": s.separated,
    }


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--out", default=str(OUT))
    a = ap.parse_args()
    t0 = time.time()
    res: dict = {"conditions": {}, "datasheet": {}}
    for name, c in CONDITIONS.items():
        rows = [ratio("fig6-period3-ideal", c["eta"], c["bits"], s) for s in range(a.seeds)]
        r = np.array([x["ratio"] for x in rows])
        res["conditions"][name] = {
            "records": rows,
            "ratios": [float(x) for x in r],
            "max": float(r.max()),
            "quantiles": {f"{q:g}": float(np.quantile(r, q)) for q in (0.5, 0.9, 0.95)},
        }
        print(name, np.round(np.sort(r), 3), flush=True)
    for eta in ("0.74", "0.712"):
        rows = [ratio("fig6-period2-datasheet", eta, 8, s) for s in range(3)]
        res["datasheet"][eta] = [x["ratio"] for x in rows]
        print("datasheet", eta, res["datasheet"][eta], flush=True)
    res["seeds"] = a.seeds
    res["elapsed_s"] = time.time() - t0
    res["platform"] = {"python": sys.version.split()[0], "machine": platform.machine()}
    out = Path(a.out)
    write_json(out / "capture_separation.json", res)
    rows = [
        (
            n,
            str(len(d["ratios"])),
            f"{d['quantiles']['0.5']:.3f}",
            f"{d['quantiles']['0.95']:.3f}",
            f"{d['max']:.3f}",
        )
        for n, d in res["conditions"].items()
    ]
    lines = [
        "# False positives of the capture score's separation (ideal vs ideal)",
        "",
        "SW / sw_floor_max of an ideal capture scored against the ideal model "
        f"({a.seeds} independent records per condition, 200 periods, 1 % noise).",
        "",
        *table(("condition", "records", "median", "95 %", "max"), rows),
        "",
        "Datasheet switched-capacitor capture vs the ideal model (3 seeds): "
        + "; ".join(
            f"eta {e}: " + ", ".join(f"{x:.3g}" for x in v) for e, v in res["datasheet"].items()
        ),
        "",
    ]
    text = "\n".join(lines)
    atomic_write(out / "capture_separation.md", lambda fh: fh.write(text), binary=False)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
