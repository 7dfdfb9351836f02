"""The paper's electronic equivalent: components, op-amp network, impact circuit, ngspice."""

__all__ = ["components", "network", "opamp", "switched", "coupled", "spice", "effects"]
