"""The mathematics, written once: exact parameters, precisions, the flow, the impact, results.

No heyoka, no I/O beyond atomic saves of results, no plotting.

* :mod:`~precise_impact.core.params` — :class:`Params` (exact rationals) and the validators.
* :mod:`~precise_impact.core.precision` — :class:`Precision`: one correct rounding per number type.
* :mod:`~precise_impact.core.flow` — the smooth flow (eq. 2a), steady state, grazing frequencies.
* :mod:`~precise_impact.core.impact` — impact map, saltation matrix, contact rule, sticking.
* :mod:`~precise_impact.core.result` — the result mixin (``to_dict``, ``save``).
* :mod:`~precise_impact.core.trajectory` — :class:`Trajectory`, what every solver returns.
"""

from precise_impact.core.params import PARAM_NAMES, RUNTIME_PARAMS, Params
from precise_impact.core.precision import Precision
from precise_impact.core.result import ResultMixin
from precise_impact.core.trajectory import Trajectory

__all__ = ["PARAM_NAMES", "RUNTIME_PARAMS", "Params", "Precision", "ResultMixin", "Trajectory"]
