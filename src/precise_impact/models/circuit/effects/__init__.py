"""One module per effect: each contributes only its own terms, states and events.

The catalogue (names, settings, units, defaults, datasheet sources) is
:mod:`.._effects`; the modules here hold the equations:

* :mod:`.opamp_offset`, :mod:`.opamp_gain`, :mod:`.opamp_gbw`, :mod:`.opamp_saturation`
  transform the op-amp stages built by :mod:`.._network`;
* :mod:`.tolerance` draws the components;
* :mod:`.comparator`, :mod:`.flipflop`, :mod:`.switch` shape the impact circuit of
  :mod:`.._switched`.

An effect that is off is never called, so it adds nothing to the compiled system.
"""
