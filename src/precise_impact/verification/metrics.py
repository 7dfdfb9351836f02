"""Error metrics between a trajectory and a reference, and the reference precision they need.

The one home of the general metrics used by the accuracy table, the scores, the
reference datasets, the work-precision harness and the main job.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from precise_impact.core.mpcontext import mp_context, mp_import
from precise_impact.core.precision import MAX_MP_BITS
from precise_impact.core.trajectory import Trajectory

if TYPE_CHECKING:
    from precise_impact.scenes.scene import Scene

__all__ = [
    "DIGITS_LOST_PER_PERIOD",
    "max_reference_periods",
    "reference_bits",
    "sample_errors",
    "scene_for_model",
]


#: Decimal digits lost per forcing period in the chaotic regime (measured: float64
#: O(1) after ~140 periods, float128 after ~290, 256 bits after ~650).
DIGITS_LOST_PER_PERIOD = 0.12


def reference_bits(periods: int, target_digits: int = 30) -> int:
    """Bits a chaotic reference needs to keep ``target_digits`` after ``periods`` periods.

    Rounded up to a multiple of 64 and at least 128; uses a 1.5x safety factor on the
    measured loss rate.
    """
    digits = target_digits + 1.5 * DIGITS_LOST_PER_PERIOD * periods + 5
    return max(128, 64 * math.ceil(digits * math.log2(10) / 64))


def max_reference_periods(target_digits: int = 30, max_bits: int | None = None) -> int:
    """Most chaotic periods a demonstrated reference can cover within the multiprecision ceiling.

    The largest ``N`` with ``reference_bits(N, target_digits) + 64 <= max_bits`` (the
    reference and its check 64 bits wider must both be allowed precisions;
    ``max_bits`` defaults to :data:`~precise_impact.core.precision.MAX_MP_BITS`).
    """

    limit = MAX_MP_BITS if max_bits is None else max_bits
    lo, hi = 0, 10**7
    while lo < hi:  # reference_bits is nondecreasing in N
        mid = (lo + hi + 1) // 2
        if reference_bits(mid, target_digits) + 64 <= limit:
            lo = mid
        else:
            hi = mid - 1
    return lo


def sample_errors(traj: Trajectory, ref: Trajectory) -> list[float]:
    """``max(|x - x_ref|, |v - v_ref|)`` at every stroboscopic sample, as floats."""
    out = []
    # a context of this thread's own: mpmath's global precision is shared by every thread
    ctx = mp_context(max(traj.precision.bits, ref.precision.bits) + 16)
    for k in range(min(len(traj.t), len(ref.t))):
        _, x, v = traj.state_mpf(k)
        _, xr, vr = ref.state_mpf(k)
        x, v = mp_import(ctx, x), mp_import(ctx, v)
        out.append(float(max(abs(x - xr), abs(v - vr))))
    return out


def scene_for_model(
    scene: Scene, model: str, periods: int | None = None
) -> tuple[Scene, list[str]]:
    """``scene`` on ``model``, keeping only the scene's effects that fit ``model``.

    A model that does not take the scene's precision runs in one it takes: a
    multiprecision-only model (``certified``) at the reference's bits for ``periods``
    (:func:`~precise_impact.verification.metrics.reference_bits`), a float64-only one in
    float64 (:meth:`~precise_impact.scenes.scene.Scene.model_settings`).

    Returns the scene and the names of the effects dropped (e.g. the comparator of a
    switched-capacitor scene when run on the op-amp ``circuit`` model).
    """
    bits = reference_bits(scene.periods if periods is None else periods)
    return scene.fitted_to(model, mp_bits=bits)
