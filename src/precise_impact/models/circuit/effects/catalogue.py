"""The catalogue of effects: physical non-idealities a scene may switch on.

Each effect is declared once (models it fits, settings with unit, default, range and the
datasheet the default comes from: TL072, LT1394, 74HC74, ADG5233; ``docs/circuit.rst``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from fractions import Fraction
from typing import Any

from precise_impact.core.params import decimal_str, exact
from precise_impact.errors import ParameterError

__all__ = ["Setting", "EffectSpec", "EFFECTS", "validate_effects", "CIRCUIT_MODELS"]

#: Models built from components (effects apply to these only).
CIRCUIT_MODELS = ("circuit", "switched-capacitor", "spice")


@dataclasses.dataclass(frozen=True)
class Setting:
    """One setting of an effect: unit, default and allowed range or choices.

    Parameters
    ----------
    unit : str
        Physical unit (``'V'``, ``'Hz'``, ``'%'``; ``'int'`` for an integer; ``''`` none).
    default : decimal or str
        Value used when a scene switches the effect on without this setting.
    lo, hi : decimal or None, default ``None``
        Allowed range (inclusive); ``None``: unbounded.
    choices : tuple, default ``()``
        Allowed values of a non-numeric setting (then ``lo``/``hi`` are unused).
    doc : str, default ``''``
        One line for the catalogue listing.
    """

    unit: str
    default: Any
    lo: Any = None
    hi: Any = None
    choices: tuple = ()
    doc: str = ""

    def check(self, effect: str, key: str, value: Any) -> Any:
        name = f"effects.{effect}.{key}"
        if self.choices:
            if value not in self.choices:
                raise ParameterError(name, value, "one of " + ", ".join(map(str, self.choices)))
            return value
        if self.unit == "int":
            if isinstance(value, bool) or not isinstance(value, int):
                raise ParameterError(name, value, "an integer")
            q = Fraction(value)
        else:
            q = exact(name, value)
        if (self.lo is not None and q < Fraction(self.lo)) or (
            self.hi is not None and q > Fraction(self.hi)
        ):
            raise ParameterError(
                name, decimal_str(q), f"allowed range {self.lo} .. {self.hi} {self.unit}"
            )
        return int(q) if self.unit == "int" else q


@dataclasses.dataclass(frozen=True)
class EffectSpec:
    """A physical non-ideality a scene may switch on (an entry of :data:`EFFECTS`).

    Parameters
    ----------
    name : str
        Key in scenes (``[effects.NAME]``) and in :data:`EFFECTS`.
    models : tuple of str
        Circuit models that implement it.
    settings : mapping of str to Setting
        Its settings with units, defaults and ranges.
    doc : str
        What it models, one line.
    """

    name: str
    models: tuple
    settings: Mapping[str, Setting]
    doc: str


EFFECTS: dict[str, EffectSpec] = {
    e.name: e
    for e in (
        EffectSpec(
            "opamp_gain",
            ("circuit", "spice"),
            {
                "A0": Setting(
                    "V/V", "200000", "10", "1e9", doc="open-loop DC gain (TL072: 200 V/mV)"
                )
            },
            "finite DC gain of U1-U4: virtual grounds sit at -V_out/A0",
        ),
        EffectSpec(
            "opamp_gbw",
            ("circuit", "spice"),
            {
                "gbw": Setting(
                    "Hz", "3e6", "1e3", "1e10", doc="gain-bandwidth product (TL072: 3 MHz)"
                ),
                "mode": Setting(
                    "",
                    "quasi-static",
                    choices=("quasi-static", "dynamic"),
                    doc=(
                        "'dynamic': each op-amp output a state (stiff); 'quasi-static': "
                        "first-order lag correction"
                    ),
                ),
            },
            "single-pole open-loop response A(s) = A0 / (1 + s A0 / (2 pi GBW))",
        ),
        EffectSpec(
            "opamp_saturation",
            ("circuit", "spice"),
            {
                "v_sat": Setting(
                    "V", "13.5", "0.5", "100", doc="output swing limit (TL072 at +-15 V: +-13.5 V)"
                )
            },
            "op-amp outputs clip at +-v_sat",
        ),
        EffectSpec(
            "opamp_offset",
            ("circuit", "spice"),
            {
                "v_os": Setting(
                    "V",
                    "3e-3",
                    "-0.1",
                    "0.1",
                    doc="input offset voltage, same sign on U1-U4 (TL072: 3 mV)",
                )
            },
            "input offset voltage at each op-amp's non-inverting input",
        ),
        EffectSpec(
            "tolerance",
            ("circuit", "switched-capacitor", "spice"),
            {
                "resistor_pct": Setting("%", "1", "0", "20"),
                "capacitor_pct": Setting("%", "5", "0", "50"),
                "seed": Setting("int", 0, 0, 2**32 - 1),
            },
            "E-series nominal values and seeded Monte Carlo draws within tolerance",
        ),
        EffectSpec(
            "comparator",
            ("switched-capacitor", "spice"),
            {
                "delay": Setting("s", "7e-9", "0", "1e-3", doc="propagation delay (LT1394: 7 ns)"),
                "hysteresis": Setting(
                    "V", "0", "0", "1", doc="total hysteresis around V_wall (LT1394: none)"
                ),
            },
            "comparator U5: trips at V_wall - hysteresis/2, re-arms at V_wall + hysteresis/2, "
            "after a delay",
        ),
        EffectSpec(
            "flipflop",
            ("switched-capacitor", "spice"),
            {
                "delay": Setting(
                    "s", "14e-9", "0", "1e-3", doc="clock-to-output delay (74HC74: ~14 ns)"
                )
            },
            "D flip-flop A1 toggles the switch polarity after its delay",
        ),
        EffectSpec(
            "switch",
            ("switched-capacitor", "spice"),
            {
                "ron": Setting(
                    "ohm",
                    "160",
                    "0",
                    "1e5",
                    doc="on-resistance per switch, two in series with C2 (ADG5233: ~160 ohm)",
                ),
                "bbm": Setting(
                    "s",
                    "0",
                    "0",
                    "1e-3",
                    doc="break-before-make interval with the feedback open (ADG433 t_D: 25 ns)",
                ),
                "charge_injection": Setting(
                    "C", "0", "-1e-9", "1e-9", doc="charge per switching onto C2 (ADG5233: ~1 pC)"
                ),
                "slew_rate": Setting(
                    "V/s",
                    "13e6",
                    "1e3",
                    "1e12",
                    doc="U2 output slew while its feedback is open (TL072: 13 V/us)",
                ),
            },
            "analog switches U6/U7 reversing C2",
        ),
    )
}

#: Settings of the "datasheet parts" scenes: every effect at its datasheet typical.
DATASHEET_SWITCH = {"ron": "160", "bbm": "25e-9", "charge_injection": "1e-12", "slew_rate": "13e6"}


def validate_effects(
    effects: Mapping[str, Mapping[str, Any]] | None, model: str
) -> dict[str, dict[str, Any]]:
    """Check effect names, that they fit ``model``, and every setting; fill defaults.

    Returns ``{effect: {setting: value}}`` with exact values.  Errors name
    ``effects.NAME`` or ``effects.NAME.KEY`` and the allowed range.
    """
    out: dict[str, dict[str, Any]] = {}
    for name, settings in (effects or {}).items():
        spec = EFFECTS.get(name)
        if spec is None:
            raise ParameterError(
                f"effects.{name}", name, "unknown effect; known: " + ", ".join(EFFECTS)
            )
        if model not in spec.models:
            raise ParameterError(
                f"effects.{name}",
                model,
                f"does not fit model '{model}'; fits: {', '.join(spec.models)}",
            )
        if settings is None or settings is True:
            settings = {}
        if not isinstance(settings, Mapping):
            raise ParameterError(
                f"effects.{name}", settings, "a table of settings (or true for the defaults)"
            )
        unknown = sorted(set(settings) - set(spec.settings))
        if unknown:
            raise ParameterError(
                f"effects.{name}.{unknown[0]}",
                settings[unknown[0]],
                "unknown setting; known: " + ", ".join(spec.settings),
            )
        vals = {}
        for key, st in spec.settings.items():
            vals[key] = st.check(name, key, settings.get(key, st.default))
        out[name] = vals
    return out
