"""Golden values of the bit-for-bit guards, one set per machine.

Bit-for-bit identity of results holds on one machine, not across machines: numpy's SIMD
dispatch, the BLAS kernels and LLVM's use of FMA differ by CPU, and move last bits.  Measured
on 2026-11-29: the goldens recorded on the earlier sessions' machine matched 12 of 24 cases of
budget, lab, coreana and orbits on an AMD EPYC, where the code before the split (ac0e85f) and
the code after it gave the same bits for all 12 (a relative 6e-13 to 0.8 apart from the
other machine's values: the 0.8 in a finite-difference check's noise-level residual).  So each
golden file holds one set of values per machine (CPU model, SIMD flags, architecture), and a
guard compares exactly with this machine's set.  On a machine without one the guard is
skipped, naming how to record one: ``python tests/structure/test_bitwise_X.py --regenerate``
with the before-code on ``PYTHONPATH`` (then the after-code must match it), or with the
current code where the before-code was checked equal on that machine.
"""

from __future__ import annotations

import hashlib
import json
import platform
import subprocess
from pathlib import Path
from typing import Any

#: CPU flags that change which machine code numpy, OpenBLAS and numba's LLVM run.
SIMD_FLAGS = ("sse4_2", "avx", "avx2", "fma", "avx512f", "avx512dq", "avx512vl", "avx512bw")


def machine() -> dict[str, Any]:
    """The CPU model, its SIMD flags and the architecture (Linux's /proc/cpuinfo)."""
    model, flags = platform.processor() or "", set()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name" and not model:
                model = value.strip()
            elif key.strip() in ("flags", "Features") and not flags:
                flags = set(value.split())
    except OSError:
        pass
    return {"arch": platform.machine(), "cpu": model, "simd": [f for f in SIMD_FLAGS if f in flags]}


def machine_key() -> str:
    return hashlib.sha256(json.dumps(machine(), sort_keys=True).encode()).hexdigest()[:16]


def cases(path: Path) -> dict[str, Any]:
    """This machine's golden cases in ``path`` (skips the test when none were recorded)."""
    import pytest

    entry = json.loads(path.read_text())["machines"].get(machine_key())
    if entry is None:
        pytest.skip(
            f"no golden values of {path.name} recorded on this machine ({machine()}): "
            f"python tests/structure/{_module(path)} --regenerate records them"
        )
    return entry["cases"]


def record(path: Path, values: dict[str, Any]) -> None:
    """This machine's cases written into ``path``, beside the other machines' sets, with the
    source they were computed by (the imported package's directory and git commit)."""
    data = json.loads(path.read_text()) if path.exists() else {"machines": {}}
    data["machines"][machine_key()] = {"machine": machine(), "source": _source(), "cases": values}
    path.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    print("wrote", path, "for", machine())


def _source() -> str:
    import precise_impact

    where = Path(precise_impact.__file__).parent
    try:
        git = ["git", "-C", str(where), "log", "-1", "--format=%h %cs"]
        head = subprocess.run(git, capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        head = "not a git checkout"
    return f"{where} ({head})"


def _module(path: Path) -> str:
    return "test_bitwise_" + path.stem.removeprefix("golden_") + ".py"
