"""Models beyond the single mechanical oscillator: the paper's circuits.

Importing this package registers ``circuit``, ``switched-capacitor`` and ``spice`` with the
model registry of :mod:`precise_impact.solvers.base`.
"""

from __future__ import annotations

from typing import Any

from precise_impact.core.precision import Precision
from precise_impact.solvers.base import PRECISION_KINDS, Capabilities, register_model

__all__ = [
    "COUPLED_FORMS",
    "CoupledTrajectory",
    "simulate_coupled",
    "certify_coupled",
    "CertifiedCoupledTrajectory",
    "Components",
    "nominal_components",
    "EFFECTS",
    "CircuitSolver",
    "SwitchedCapacitorSolver",
    "SpiceSolver",
    "CoupledCircuitTrajectory",
    "simulate_coupled_circuit",
]


def _circuit(prec: Precision, tol: Any, **options: Any):
    return CircuitSolver(prec, tol, **options)


def _switched(prec: Precision, tol: Any, **options: Any):
    return SwitchedCapacitorSolver(prec, tol, **options)


def _spice(prec: Precision, tol: Any, **options: Any):
    return SpiceSolver(**options)


register_model(
    "circuit",
    "the op-amp network of Fig. 2 with the mechanical impact law (nominal parts)",
    _circuit,
    Capabilities(PRECISION_KINDS, tolerance=True),
)
register_model(
    "switched-capacitor",
    "the impact made by the circuit: comparator, flip-flop, switches",
    _switched,
    Capabilities(PRECISION_KINDS, tolerance=True),
)
register_model(
    "spice",
    "the Fig. 2 circuit as an ngspice netlist (float64; needs ngspice)",
    _spice,
    Capabilities(("float64",), tolerance=False, note="ngspice's arithmetic; use tmax"),
)

# The public names (after the registration, which needs none of them).
from precise_impact.models.circuit.components import Components, nominal_components  # noqa: E402
from precise_impact.models.circuit.coupled import CoupledCircuitTrajectory, simulate_coupled_circuit  # noqa: E402
from precise_impact.models.circuit.effects.catalogue import EFFECTS  # noqa: E402
from precise_impact.models.circuit.opamp import CircuitSolver  # noqa: E402
from precise_impact.models.circuit.spice import SpiceSolver  # noqa: E402
from precise_impact.models.circuit.switched import SwitchedCapacitorSolver  # noqa: E402
from precise_impact.solvers.certified.coupled import CertifiedCoupledTrajectory, certify_coupled  # noqa: E402
from precise_impact.solvers.heyoka.coupled import COUPLED_FORMS, CoupledTrajectory, simulate_coupled  # noqa: E402
