"""The paper's electronic equivalent: components, the op-amp network, the impact circuit, ngspice.

* :mod:`~precise_impact.models.circuit.components` — component values and the mapping to the
  dimensionless system (written once).
* :mod:`~precise_impact.models.circuit.network` — the op-amp network (Fig. 2) with its effects.
* :mod:`~precise_impact.models.circuit.opamp` — :class:`CircuitSolver` (mechanical impact law on ``V_q``).
* :mod:`~precise_impact.models.circuit.switched` — :class:`SwitchedCapacitorSolver` (comparator,
  flip-flop, switches).
* :mod:`~precise_impact.models.circuit.coupled` — the Fig. 3 coupled circuit.
* :mod:`~precise_impact.models.circuit.spice` — the ngspice netlist and :class:`SpiceSolver`.
* :mod:`~precise_impact.models.circuit.effects` — one module per physical non-ideality.
"""

__all__ = ["components", "network", "opamp", "switched", "coupled", "spice", "effects"]
