"""mpmath contexts of their own: thread-safe multiprecision without mpmath's global precision.

mpmath's module-level context (``mpmath.mp``; ``mpmath.workprec`` / ``workdps`` change it) is
one setting of the process: two threads computing at different precisions change each other's
results.  The package computes in contexts of its own instead: numbers made by ``ctx.mpf`` /
``ctx.make_mpf`` compute at ``ctx.prec`` whatever the global precision is.  ``a + b`` computes at
the precision of ``a``'s context, so inputs are brought into the computation's context first
(:func:`mp_import`, exact) and results handed to callers leave it (:func:`mp_export`).
"""

from __future__ import annotations

import threading
from typing import Any

import mpmath

__all__ = ["mp_context", "mp_export", "mp_import"]

_LOCAL = threading.local()


def mp_context(bits: int) -> Any:
    """This thread's :class:`mpmath.MPContext` at ``bits`` of precision.

    mpmath's module-level context (``mpmath.mp``, and ``mpmath.workprec``/``workdps``, which
    change it) is shared by every thread: two threads computing at different precisions change
    each other's results.  A context of its own per thread and precision does not; numbers
    made by ``ctx.mpf`` / ``ctx.make_mpf`` compute at ``ctx.prec`` whatever the module-level
    precision.  Numbers handed to callers go out through :func:`mp_export`.  Never set the
    returned context's ``prec`` (mpmath's own routines such as ``lu_solve`` raise it and restore
    it, which is safe only because the context belongs to one thread).
    """
    cache = getattr(_LOCAL, "contexts", None)
    if cache is None:
        cache = _LOCAL.contexts = {}
    ctx = cache.get(bits)
    if ctx is None:
        ctx = mpmath.MPContext()
        ctx.prec = bits
        cache[bits] = ctx
    return ctx


def mp_export(z: Any) -> Any:
    """A number of any mpmath context as the module-level ``mpmath.mpf`` / ``mpc`` of the same
    value (exactly: no rounding), so that it is not tied to a thread's context."""
    if hasattr(z, "_mpf_"):
        return mpmath.mp.make_mpf(z._mpf_)
    if hasattr(z, "_mpc_"):
        return mpmath.mp.make_mpc(z._mpc_)
    return z


def mp_import(ctx: Any, z: Any) -> Any:
    """An mpmath number (of any context) as a number of ``ctx``, exactly (no rounding)."""
    if hasattr(z, "_mpf_"):
        return ctx.make_mpf(z._mpf_)
    if hasattr(z, "_mpc_"):
        return ctx.make_mpc(z._mpc_)
    return ctx.convert(z)
