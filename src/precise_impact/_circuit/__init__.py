"""The electronic equivalent: component values, the op-amp network model, the switched-capacitor impact."""
