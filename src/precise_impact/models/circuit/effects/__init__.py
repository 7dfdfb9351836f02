"""One module per effect: each contributes only its own terms, states and events.

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
