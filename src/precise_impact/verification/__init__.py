"""Scoring models against demonstrated references.

* :mod:`~precise_impact.verification.metrics` — sample errors and the reference precision they need.
* :mod:`~precise_impact.verification.accuracy` — every model and precision against the reference.
* :mod:`~precise_impact.verification.scores` — periodic and chaotic scores (horizons, Wasserstein ...).
* :mod:`~precise_impact.verification.compare` — a scene's models scored, with report and plots.
* :mod:`~precise_impact.verification.reference` — the shipped reference datasets: generate, verify.
* :mod:`~precise_impact.verification.workprecision` — error against wall time.
* :mod:`~precise_impact.verification.reproduce` — the main job: the paper's figures side by side.
"""

__all__ = ["metrics", "accuracy", "scores", "compare", "reference", "workprecision", "reproduce"]
