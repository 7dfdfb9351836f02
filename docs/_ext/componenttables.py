"""Tables of the circuit-builders page generated from the code, so they cannot drift.

``.. components-table::``
    Every key a scene's ``[components]`` table accepts
    (:data:`precise_impact.scenes.scene.COMPONENT_KEYS`), its unit, its value in the nominal
    design of the paper's parameters
    (:func:`~precise_impact.models.circuit.components.nominal_components`) and what
    multiplying it by 4 does to the system the circuit realises: the exact factors
    by which ``zeta``, ``a``, ``eta``, ``x_w`` and the three scales change, computed by
    :func:`~precise_impact.models.circuit.components.dimensionless` (a factor 4 keeps
    ``omega`` rational).

``.. effects-table::``
    Every effect of :data:`~precise_impact.models.circuit.effects.catalogue.EFFECTS` with
    the models that implement it and its settings (unit, default, range).
"""

from __future__ import annotations

import inspect
from fractions import Fraction

from docutils import nodes
from sphinx.util.docutils import SphinxDirective


def _table(header: list[str], rows: list[list[str]], widths: list[int]) -> nodes.table:
    table = nodes.table()
    group = nodes.tgroup(cols=len(header))
    table += group
    for w in widths:
        group += nodes.colspec(colwidth=w)
    head = nodes.thead()
    group += head
    body = nodes.tbody()
    group += body
    for cells, parent in [(header, head)] + [(r, body) for r in rows]:
        row = nodes.row()
        for text in cells:
            entry = nodes.entry()
            entry += nodes.paragraph(text="") if not text else _literal_aware(text)
            row += entry
        parent += row
    return table


def _literal_aware(text: str) -> nodes.paragraph:
    """A paragraph where ``name`` spans become literals."""
    para = nodes.paragraph()
    parts = text.split("``")
    for i, part in enumerate(parts):
        if part:
            para += nodes.literal(part, part) if i % 2 else nodes.Text(part)
    return para


def _fmt_factor(q: Fraction) -> str:
    return f"\u00d7{q.numerator}" + ("" if q.denominator == 1 else f"/{q.denominator}")


def _quantity(value: Fraction, unit: str) -> str:
    prefixes = [
        (Fraction(10**9), "G"),
        (Fraction(10**6), "M"),
        (Fraction(10**3), "k"),
        (1, ""),
        (Fraction(1, 10**3), "m"),
        (Fraction(1, 10**6), "u"),
        (Fraction(1, 10**9), "n"),
        (Fraction(1, 10**12), "p"),
    ]
    for scale, p in prefixes:
        if abs(value) >= scale:
            v = value / scale
            s = f"{float(v):.6g}"
            return f"{s} {p}{'Ohm' if unit == 'ohm' else unit}"
    return f"{float(value):.6g} {unit}"


def _realised(comp):
    """What a design realises: the dimensionless parameters and the three scales."""
    from precise_impact.models.circuit.components import dimensionless, exact_omega

    p = dimensionless(comp)
    w = exact_omega(comp)
    return {
        "zeta": p.zeta,
        "a": p.a,
        "eta": p.eta,
        "x_w": p.x_w,
        "seconds per tau": 1 / w,
        "volts per x": comp.V_unit,
        "volts per x'": w * comp.R8 * comp.C1 * comp.V_unit,
    }


class ComponentsTable(SphinxDirective):
    has_content = False

    def run(self):
        from precise_impact.core.params import Params
        from precise_impact.models.circuit.components import nominal_components
        from precise_impact.scenes.scene import COMPONENT_KEYS

        params = Params.make()
        defaults = {
            k: Fraction(str(v.default))
            for k, v in inspect.signature(nominal_components).parameters.items()
            if k in ("R", "C", "V_unit")
        }
        base = nominal_components(params)
        before = _realised(base)
        rows = []
        for key, unit in COMPONENT_KEYS.items():
            if key in defaults:
                value = defaults[key]
                kw = {k: v for k, v in defaults.items()}
                kw[key] = 4 * value
                changed = nominal_components(params, **kw)
                what = {
                    "R": "every resistor but R6 = R / (2 zeta)",
                    "C": "C1 and C2",
                    "V_unit": "the volts of one unit of x",
                }[key]
                nominal = f"{_quantity(value, unit)} ({what})"
            else:
                value = getattr(base, key)
                changed = base.replace(**{key: 4 * value})
                nominal = _quantity(value, unit)
            after = _realised(changed)
            effect = ", ".join(
                f"``{name}`` {_fmt_factor(after[name] / before[name])}"
                for name in before
                if after[name] != before[name]
            )
            rows.append([f"``{key}``", unit, nominal, effect or "nothing"])
        return [
            _table(
                ["key", "unit", "nominal (paper's parameters)", "\u00d74 changes"],
                rows,
                [8, 5, 40, 60],
            )
        ]


class EffectsTable(SphinxDirective):
    has_content = False

    def run(self):
        from precise_impact.models.circuit.effects.catalogue import EFFECTS

        rows = []
        for name, spec in EFFECTS.items():
            settings = []
            for key, st in spec.settings.items():
                unit = "" if st.unit in ("", "int") else f" {st.unit}"
                if st.choices:
                    rng = "one of " + ", ".join(map(str, st.choices))
                else:
                    rng = f"{st.lo} .. {st.hi}"
                settings.append(f"``{key}`` = {st.default}{unit} ({rng}): {st.doc}".rstrip(": "))
            rows.append([f"``{name}``", ", ".join(spec.models), spec.doc, "; ".join(settings)])
        header = ["effect", "models", "what", "settings: default (range)"]
        return [_table(header, rows, [12, 16, 30, 60])]


def setup(app):
    app.add_directive("components-table", ComponentsTable)
    app.add_directive("effects-table", EffectsTable)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
