"""Scoring models against demonstrated references.

* :mod:`~precise_impact.verification.metrics` — sample errors and the reference precision they need.
* :mod:`~precise_impact.verification.accuracy` — every model and precision against the reference.
* :mod:`~precise_impact.verification.scores` — periodic and chaotic scores (horizons, Wasserstein ...).
* :mod:`~precise_impact.verification.compare` — a scene's models scored, with report and plots.
* :mod:`~precise_impact.verification.reference` — the shipped reference datasets: generate, verify.
* :mod:`~precise_impact.verification.workprecision` — error against wall time.
* :mod:`~precise_impact.verification.reproduce` — the main job: the paper's figures side by side.
"""

from precise_impact.verification.accuracy import AccuracyResult, accuracy_table
from precise_impact.verification.compare import CompareResult, compare
from precise_impact.verification.reference import generate as generate_reference
from precise_impact.verification.reference import verify as verify_reference
from precise_impact.verification.reproduce import ReproduceResult, reproduce
from precise_impact.verification.scores import score
from precise_impact.verification.workprecision import WorkPrecisionResult, work_precision

__all__ = [
    "AccuracyResult",
    "accuracy_table",
    "score",
    "CompareResult",
    "compare",
    "generate_reference",
    "verify_reference",
    "WorkPrecisionResult",
    "work_precision",
    "ReproduceResult",
    "reproduce",
]
