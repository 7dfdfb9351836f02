"""Component values of the circuit (paper Fig. 2) and the mapping to the dimensionless system.

Written once for every circuit model.  The printed eq. (5b) carries a sign slip; the mapping is
derived in ``docs/circuit.rst``.
"""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction
from typing import Any

import mpmath
from mpmath import libmp

from precise_impact.core.mpcontext import mp_context, mp_export
from precise_impact.core.params import Params, as_params, decimal_str, exact
from precise_impact.errors import ParameterError
from precise_impact.io.figures import register_circuit_units

__all__ = [
    "design_and_start",
    "Components",
    "nominal_components",
    "dimensionless",
    "exact_omega",
    "to_mechanical",
    "to_circuit",
    "circuit_scales",
    "CircuitScales",
    "COMPONENT_UNITS",
]

#: Each component and its SI unit.
COMPONENT_UNITS = {
    "R1": "ohm",
    "R2": "ohm",
    "R3": "ohm",
    "R4": "ohm",
    "R5": "ohm",
    "R6": "ohm",
    "R7": "ohm",
    "R8": "ohm",
    "C1": "F",
    "C2": "F",
    "V_A": "V",
    "Omega": "rad/s",
    "V_wall": "V",
    "V_unit": "V",
}


@dataclasses.dataclass(frozen=True)
class Components:
    """Component values, exact rationals in SI units (ohm, farad, volt, rad/s).

    ``V_unit`` is the voltage that represents one unit of the dimensionless
    displacement (1 V by default).  Construct with :meth:`make` (validated) or
    :func:`nominal_components`.

    See Also
    --------
    precise_impact.models.circuit.components.nominal_components
        The ideal values for a set of parameters.
    precise_impact.models.circuit.opamp.CircuitSolver : the circuit that uses them.
    """

    R1: Fraction
    R2: Fraction
    R3: Fraction
    R4: Fraction
    R5: Fraction
    R6: Fraction
    R7: Fraction
    R8: Fraction
    C1: Fraction
    C2: Fraction
    V_A: Fraction
    Omega: Fraction
    V_wall: Fraction
    V_unit: Fraction = Fraction(1)

    @classmethod
    def make(cls, **values: Any) -> Components:
        unknown = sorted(set(values) - set(COMPONENT_UNITS))
        if unknown:
            raise ParameterError(
                unknown[0],
                values[unknown[0]],
                "unknown component; known: " + ", ".join(COMPONENT_UNITS),
            )
        missing = [n for n in COMPONENT_UNITS if n not in values and n != "V_unit"]
        if missing:
            raise ParameterError(missing[0], None, "component value missing")
        q = {n: exact(n, v) for n, v in values.items()}
        for n, v in q.items():
            if COMPONENT_UNITS[n] in ("ohm", "F") and v <= 0:
                raise ParameterError(n, decimal_str(v), f"a {COMPONENT_UNITS[n]} value must be > 0")
        if q.get("Omega", 1) <= 0:
            raise ParameterError(
                "Omega", decimal_str(q["Omega"]), "forcing angular frequency must be > 0 rad/s"
            )
        if q.get("V_unit", 1) <= 0:
            raise ParameterError(
                "V_unit", decimal_str(q["V_unit"]), "volts per unit displacement must be > 0"
            )
        return cls(**q)

    def replace(self, **values: Any) -> Components:
        d = dataclasses.asdict(self)
        d.update(values)
        return Components.make(**d)

    def decimal(self) -> dict[str, str]:
        return {n: decimal_str(getattr(self, n)) for n in COMPONENT_UNITS}

    # the mapping, written once ---------------------------------------------------
    @property
    def omega_squared(self) -> Fraction:
        """``omega^2 = R2 / (R7 R3 C2 R8 C1)`` [1/s^2] (exact)."""
        return self.R2 / (self.R7 * self.R3 * self.C2 * self.R8 * self.C1)

    def omega(self, dps: int = 40) -> mpmath.mpf:
        """Natural angular frequency [rad/s] (an mpmath number: sqrt is irrational in general)."""
        mp = mp_context(libmp.dps_to_prec(dps))  # this thread's own: the global one is shared
        w2 = self.omega_squared
        return mp_export(mp.sqrt(mp.mpf(w2.numerator) / w2.denominator))


def dimensionless(comp: Components, x0: Any = 0, v0: Any = 0, t0: Any = 0, R: Any = 1) -> Params:
    """The mechanical :class:`Params` the ideal circuit realises (exact when omega is rational).

    ``zeta = R2 R5 / (2 R4 R6 R3 C2 omega)``, ``a = V_A R7 / (R1 V_unit)``,
    ``eta = Omega / omega``, ``x_w = -V_wall / V_unit``.  ``omega`` must be rational
    (e.g. R3 C2 = R8 C1 and R2 = R7, as in the paper's design); otherwise a
    :class:`ParameterError` names the components.
    """
    w = exact_omega(comp)
    zeta = comp.R2 * comp.R5 / (2 * comp.R4 * comp.R6 * comp.R3 * comp.C2 * w)
    return Params.make(
        zeta=zeta,
        a=comp.V_A * comp.R7 / (comp.R1 * comp.V_unit),
        eta=comp.Omega / w,
        x_w=-comp.V_wall / comp.V_unit,
        R=R,
        x0=x0,
        v0=v0,
        t0=t0,
    )


def exact_omega(comp: Components) -> Fraction:
    """``omega`` as an exact rational, or :class:`ParameterError` if it is irrational."""
    w2 = comp.omega_squared
    if not OMEGA_RANGE[0] ** 2 <= w2 <= OMEGA_RANGE[1] ** 2:
        raise ParameterError(
            "R2, R7, R3, C2, R8, C1",
            f"omega = {float(w2) ** 0.5:.3g} rad/s",
            f"a design with {OMEGA_RANGE[0]:g} <= omega = sqrt(R2/(R7 R3 C2 R8 C1)) <= "
            f"{OMEGA_RANGE[1]:g} rad/s (beyond it the circuit's time and voltage scales leave "
            "float64)",
        )
    root = _isqrt_fraction(w2)
    if root is None:
        raise ParameterError(
            "R2, R7, R3, C2, R8, C1",
            decimal_str(w2),
            "omega^2 = R2/(R7 R3 C2 R8 C1) must be a rational square for an exact mapping (design "
            "values)",
        )
    return root


#: The circuit's natural angular frequency ``omega = 1/(R C)`` a design may have, rad/s.  The
#: circuit models integrate in seconds, so the k-th Taylor coefficient of a state scales as
#: omega^k: with float64's range (1e+-308) and heyoka's orders (~20 at float64 tolerances)
#: |log10 omega| must stay below ~15.  1e-6 .. 1e9 rad/s (0.16 uHz .. 160 MHz) holds every lumped
#: analog design with margin (measured: omega = 1e18, R = 1e-11 ohm with C = 100 nF, stopped
#: heyoka with a NaN step; R = 2e-79 ohm overflowed omega^2 V).
OMEGA_RANGE = (1e-6, 1e9)


def _isqrt_fraction(q: Fraction) -> Fraction | None:
    n, d = q.numerator, q.denominator
    rn, rd = math.isqrt(n), math.isqrt(d)
    if rn * rn == n and rd * rd == d:
        return Fraction(rn, rd)
    return None


def nominal_components(
    params: Params, R: Any = "10e3", C: Any = "100e-9", V_unit: Any = 1
) -> Components:
    """Ideal-design component values realising ``params`` (paper's design rules).

    ``R1 = R2 = R3 = R4 = R5 = R7 = R8 = R``, ``C1 = C2 = C`` (so ``omega = 1/(R C)``,
    1000 rad/s with the defaults 10 kOhm, 100 nF), ``R6 = R2 / (2 zeta)`` (100 kOhm for
    zeta = 0.05), ``V_A = a V_unit``, ``Omega = eta omega``, ``V_wall = -x_w V_unit``.

    Parameters
    ----------
    params : Params
        Dimensionless system (``zeta > 0``).
    R : decimal, default ``'10e3'``
        The common resistance in ohms.
    C : decimal, default ``'100e-9'``
        The common capacitance in farads.
    V_unit : decimal, default 1
        Volts per unit of the dimensionless displacement.

    Returns
    -------
    Components
        Exact component values (Fractions).

    Raises
    ------
    ParameterError
        ``zeta = 0`` (R6 would be infinite: leave the damping resistor out by giving
        a huge R6 through :meth:`Components.replace`), ``R != 1`` (the circuits' impact
        reverses the velocity with unit gain: a run at ``R = 0.8`` was silently one at
        ``R = 1``) or a non-positive value.

    See Also
    --------
    precise_impact.models.circuit.components.Components : the component values returned.
    precise_impact.models.circuit.opamp.CircuitSolver : the circuit that uses them.
    precise_impact.models.circuit.coupled.simulate_coupled_circuit : two coupled circuits.

    References
    ----------
    .. [1] V. Denysenko, M. Balcerzak, A. Dabrowski, "Electronic equivalent of a
           mechanical impact oscillator", eqs. (3)-(9) and Fig. 2.

    Examples
    --------
    >>> import precise_impact as pi
    >>> c = pi.nominal_components(pi.Params.make(eta="0.74"))
    >>> type(c).__name__
    'Components'
    """

    params = as_params(params)
    r, c, vu = exact("R", R), exact("C", C), exact("V_unit", V_unit)
    if r <= 0 or c <= 0:
        raise ParameterError("R" if r <= 0 else "C", decimal_str(r if r <= 0 else c), "must be > 0")
    if params.zeta == 0:
        raise ParameterError("zeta", "0", "the circuit realises zeta > 0 (R6 = R2 / (2 zeta))")
    if params.R != 1:  # every circuit model reverses V_q with unit gain at the wall
        raise ParameterError(
            "R",
            decimal_str(params.R),
            "R = 1 for the circuits (their impact reverses V_q with unit gain)",
        )
    w = 1 / (r * c)
    if not OMEGA_RANGE[0] <= w <= OMEGA_RANGE[1]:
        raise ParameterError(
            "R, C",
            f"{decimal_str(r)}, {decimal_str(c)}",
            f"{OMEGA_RANGE[0]:g} <= omega = 1/(R C) <= {OMEGA_RANGE[1]:g} rad/s",
        )
    try:
        return Components.make(
            R1=r,
            R2=r,
            R3=r,
            R4=r,
            R5=r,
            R6=r / (2 * params.zeta),
            R7=r,
            R8=r,
            C1=c,
            C2=c,
            V_A=params.a * vu,
            Omega=params.eta * w,
            V_wall=-params.x_w * vu,
            V_unit=vu,
        )
    except ParameterError as e:  # a derived value out of range: name what the caller gave
        # the system parameter a derived component also depends on (R6 = R / (2 zeta), ...)
        param = {"R6": ", zeta", "Omega": ", eta", "V_A": ", a", "V_wall": ", x_w"}.get(e.name, "")
        raise ParameterError(
            "R, C, V_unit" + param,
            f"{decimal_str(r)}, {decimal_str(c)}, {decimal_str(vu)}",
            f"values whose derived component {e.name} is in range ({e.allowed})",
        ) from None


def to_mechanical(comp: Components, t: Any, V_s: Any, V_q: Any, omega: Any):
    """Circuit state (seconds, volts) -> dimensionless ``(tau, x, x')``.

    ``tau = omega t``, ``x = -V_s / V_unit``, ``x' = V_q / (omega R8 C1 V_unit)``.
    Works elementwise on numpy arrays and on mpmath/heyoka numbers; ``omega`` in the
    caller's number type (``comp.omega()`` rounded to it).
    """
    vu = comp.V_unit
    rc = comp.R8 * comp.C1
    return omega * t, -V_s / _num(vu, V_s), V_q / (omega * _num(rc, V_q) * _num(vu, V_q))


def to_circuit(comp: Components, tau: Any, x: Any, v: Any, omega: Any):
    """Dimensionless ``(tau, x, x')`` -> circuit ``(t, V_s, V_q)`` (inverse of
    :func:`to_mechanical`)."""
    vu = comp.V_unit
    rc = comp.R8 * comp.C1
    return tau / omega, -x * _num(vu, x), v * omega * _num(rc, v) * _num(vu, v)


@dataclasses.dataclass(frozen=True)
class CircuitScales:
    """The mapping between the dimensionless system and the circuit's seconds and volts,
    as float64 factors (for plots and tables; :func:`to_circuit` is the exact form).

    ``t [s] = seconds_per_tau * tau``, ``V_s [V] = volts_per_x * x``,
    ``V_q [V] = volts_per_v * x'`` with ``seconds_per_tau = 1 / omega``,
    ``volts_per_x = -V_unit`` (the integrator's output is ``-x``) and
    ``volts_per_v = omega R8 C1 V_unit``; ``omega = sqrt(R2 / (R7 R3 C2 R8 C1))`` rad/s.
    The wall ``x = x_w`` is ``V_s = -x_w V_unit = V_wall``.

    Attributes
    ----------
    omega : float
        Natural angular frequency [rad/s].
    seconds_per_tau, volts_per_x, volts_per_v : float
        The three factors.

    See Also
    --------
    precise_impact.models.circuit.components.circuit_scales : builds it.
    precise_impact.io.figures.PlotUnits : the plots' units, built from it.
    """

    omega: float
    seconds_per_tau: float
    volts_per_x: float
    volts_per_v: float


def circuit_scales(comp: Components) -> CircuitScales:
    """The seconds and volts of ``comp``'s circuit per unit of dimensionless ``tau``, ``x``
    and ``x'`` (the one home of the volts-to-x mapping for plots: :class:`CircuitScales`).

    Examples
    --------
    >>> import precise_impact as pi
    >>> from precise_impact.models.circuit.components import circuit_scales
    >>> s = circuit_scales(pi.nominal_components(pi.Params.make()))  # 10 kOhm, 100 nF
    >>> s.omega, s.seconds_per_tau, s.volts_per_x, s.volts_per_v
    (1000.0, 0.001, -1.0, 1.0)
    """
    w = float(comp.omega())
    vu = float(comp.V_unit)
    return CircuitScales(
        omega=w,
        seconds_per_tau=1.0 / w,
        volts_per_x=-vu,
        volts_per_v=w * float(comp.R8 * comp.C1) * vu,
    )


register_circuit_units(nominal_components, circuit_scales)


def _num(q: Fraction, like: Any):
    """An exact rational rounded to the number type of ``like``: mpmath for mpmath
    numbers (in ``like``'s context, at its precision), float64 otherwise."""
    if hasattr(like, "_mpf_"):
        return like.context.mpf(q.numerator) / q.denominator
    return float(q)


def design_and_start(system: Params | Components, x0: Any = None, v0: Any = None, t0: Any = None):
    """``(design, x0, v0, t0)`` for a circuit solve, from parameters or from components.

    This is what lets the circuit models implement the :class:`~precise_impact.solvers.base.Solver`
    protocol (``solve(params, periods)``) and still take a design of their own.

    Parameters
    ----------
    system : Params or Components
        ``Params``: the nominal design realising them (:func:`nominal_components`) and
        their initial condition (unless ``x0``, ``v0``, ``t0`` are given);
        ``Components``: that design, started from ``x0``, ``v0``, ``t0`` (default 0).
    x0, v0, t0 : decimal or None, default ``None``
        Dimensionless initial condition overriding the one of ``system``.

    Returns
    -------
    tuple
        ``(Components, x0, v0, t0)``, the initial condition as Fractions.
    """
    if isinstance(system, Params):
        design = nominal_components(system)
        pick = lambda given, own: own if given is None else given  # noqa: E731
        return design, pick(x0, system.x0), pick(v0, system.v0), pick(t0, system.t0)
    if isinstance(system, Components):
        return system, 0 if x0 is None else x0, 0 if v0 is None else v0, 0 if t0 is None else t0
    raise ParameterError("params", type(system).__name__, "a Params or a Components object")
