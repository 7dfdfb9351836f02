"""Scoring models against demonstrated references."""

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
