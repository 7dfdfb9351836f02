"""The mathematics, written once: exact parameters, precisions, the flow, the impact, results.

No heyoka, no I/O beyond atomic saves of results, no plotting.
"""

from precise_impact.core.params import PARAM_NAMES, RUNTIME_PARAMS, Params
from precise_impact.core.precision import Precision
from precise_impact.core.result import ResultMixin
from precise_impact.core.trajectory import Trajectory

__all__ = ["PARAM_NAMES", "RUNTIME_PARAMS", "Params", "Precision", "ResultMixin", "Trajectory"]
