"""A reference case's ``manifest.json``: versions, checksums, written last (atomically).

The layer under :mod:`~precise_impact.verification.reference` (which generates and verifies the
cases) that the case writers it calls (:mod:`~precise_impact.verification.certificate`,
:mod:`~precise_impact.verification.proven_landmarks`) share with it.
"""

from __future__ import annotations

import datetime as _dt
import json
import platform
from collections.abc import Sequence
from pathlib import Path

import mpmath
import numpy as np

from precise_impact.io.atomic import sha256_file
from precise_impact.io.jsonout import write_json
from precise_impact.version import __version__

__all__ = ["CERTIFICATE_FILE", "FORMAT_VERSION", "MANIFEST", "read_manifest", "write_manifest"]

FORMAT_VERSION = 1

MANIFEST = "manifest.json"
#: The proof beside a single case (:mod:`precise_impact.verification.certificate`).
CERTIFICATE_FILE = "certificate.json"


def _versions() -> dict[str, str]:
    import heyoka  # noqa: PLC0415 -- heavy: heyoka, loaded when a case is written

    return {
        "precise_impact": __version__,
        "heyoka": getattr(heyoka, "__version__", "unknown"),
        "numpy": np.__version__,
        "mpmath": mpmath.__version__,
        "python": platform.python_version(),
    }


def write_manifest(case_dir: Path, files: Sequence[str], manifest: dict) -> dict:
    """Checksum ``files`` and write the manifest last (atomically)."""
    manifest = dict(manifest)
    manifest["format_version"] = FORMAT_VERSION
    manifest["versions"] = _versions()
    manifest["generated_utc"] = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    manifest["files"] = {
        name: {"sha256": sha256_file(case_dir / name), "bytes": (case_dir / name).stat().st_size}
        for name in files
    }
    write_json(case_dir / MANIFEST, manifest)
    return manifest


def read_manifest(case_dir: Path) -> dict:
    with open(Path(case_dir) / MANIFEST) as fh:
        return json.load(fh)
