"""One module per effect: each contributes only its own terms, states and events.

The catalogue (names, settings, units, defaults, datasheet sources) is
:mod:`precise_impact.models.circuit.effects.catalogue`; the modules here hold the equations:

* :mod:`precise_impact.models.circuit.effects.opamp_offset`, :mod:`precise_impact.models.circuit.effects.opamp_gain`, :mod:`precise_impact.models.circuit.effects.opamp_gbw`, :mod:`precise_impact.models.circuit.effects.opamp_saturation`
  transform the op-amp stages built by :mod:`precise_impact.models.circuit.network`;
* :mod:`precise_impact.models.circuit.effects.tolerance` draws the components;
* :mod:`precise_impact.models.circuit.effects.comparator`, :mod:`precise_impact.models.circuit.effects.flipflop`, :mod:`precise_impact.models.circuit.effects.switch` shape the impact circuit of
  :mod:`precise_impact.models.circuit.switched`.

An effect that is off is never called, so it adds nothing to the compiled system.
"""

__all__ = [
    "catalogue",
    "comparator",
    "flipflop",
    "opamp_gain",
    "opamp_gbw",
    "opamp_offset",
    "opamp_saturation",
    "switch",
    "tolerance",
]
