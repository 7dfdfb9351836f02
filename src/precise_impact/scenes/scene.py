"""Scenes: declarative TOML descriptions of one simulation, validated before any work.

Unknown keys, wrong units, out-of-range values and effects that do not fit the model are
refused with an error naming the key (format: ``docs/design.rst``).
"""

from __future__ import annotations

import dataclasses
import re
import stat
import tomllib
import warnings
from collections.abc import Mapping
from fractions import Fraction
from importlib import resources
from pathlib import Path
from typing import Any

from precise_impact.core.params import PARAM_NAMES, Params, check_count, decimal_str, exact
from precise_impact.core.precision import Precision
from precise_impact.errors import ParameterError
from precise_impact.models.circuit.components import exact_omega, nominal_components
from precise_impact.models.circuit.effects.catalogue import (
    CIRCUIT_MODELS,
    EFFECTS,
    validate_effects,
)
from precise_impact.solvers import simulate as _registers_the_solvers_models  # noqa: F401
from precise_impact.solvers.base import COUPLED_MODELS, MODEL_ALIASES, MODELS, model_capabilities
from precise_impact.solvers.heyoka.coupled import check_form, check_k

__all__ = [
    "Scene",
    "load_scene",
    "builtin_scenes",
    "SCENE_MODELS",
    "COMPONENT_KEYS",
    "SCENE_ALIASES",
    "scene_alias",
    "parse_quantity",
]

#: Old built-in scene names -> the names of what they show (issue 27: the datasheet model of
#: Fig. 4 is chaotic, of Fig. 6 on a period-2 orbit).  Accepted for one release, with a
#: :class:`DeprecationWarning` (the CLI: one line on stderr).
SCENE_ALIASES = {
    "fig4-periodic-datasheet": "fig4-chaotic-datasheet",
    "fig6-period3-datasheet": "fig6-period2-datasheet",
}


def scene_alias(spec: str | Path) -> str | None:
    """The one-line notice for a deprecated built-in scene name, or ``None``."""
    new = SCENE_ALIASES.get(str(spec))
    if new is None or str(spec) in builtin_scenes():
        return None
    return (
        f"scene {str(spec)!r} is deprecated, use {new!r} (named for what it shows; the old name "
        "is removed in the next release)"
    )


#: The models a scene runs on: every registered model (a live view of
#: :data:`~precise_impact.solvers.base.MODELS`, so a model registered later is accepted too).
SCENE_MODELS = MODELS
#: The keys a scene's ``[components]`` table accepts, each with its unit: the design values
#: ``R``, ``C``, ``V_unit`` of :func:`nominal_components` and any single resistor or capacitor
#: overriding the nominal design (``docs/guide/circuit_builders.rst`` is generated from it).
COMPONENT_KEYS = {
    "R": "ohm",
    "C": "F",
    "V_unit": "V",
    **{f"R{i}": "ohm" for i in range(1, 9)},
    "C1": "F",
    "C2": "F",
}
_TOP = {
    "name",
    "description",
    "system",
    "model",
    "parameters",
    "components",
    "effects",
    "duration",
    "outputs",
}
_SECTIONS = {
    "system": {"kind", "form", "k"},
    "model": {"name", "precision", "tol", "tmax"},
    "duration": {"periods"},
    "outputs": {"per_period"},
    "components": set(COMPONENT_KEYS),
}
_PREFIX = {
    "p": Fraction(1, 10**12),
    "n": Fraction(1, 10**9),
    "u": Fraction(1, 10**6),
    "µ": Fraction(1, 10**6),
    "m": Fraction(1, 1000),
    "": Fraction(1),
    "k": Fraction(1000),
    "M": Fraction(10**6),
    "G": Fraction(10**9),
}
_UNIT_ALIASES = {
    "ohm": "ohm",
    "Ω": "ohm",
    "F": "F",
    "V": "V",
    "s": "s",
    "Hz": "Hz",
    "C": "C",
    "V/V": "V/V",
    "%": "%",
    "V/s": "V/s",
}


def parse_quantity(name: str, value: Any, unit: str) -> Fraction:
    """A number, or a string ``"<decimal> [prefix]<unit>"`` whose unit must be ``unit``.

    ``"10 kohm"``, ``"100nF"``, ``"7 ns"``, ``"160"`` (bare: in ``unit``).  A wrong
    unit (``"160 s"`` for an ohm value) raises :class:`ParameterError` naming ``name``.
    """
    if isinstance(value, str):
        m = re.fullmatch(
            r"\s*([-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?(?:/[0-9]+)?)\s*([a-zA-Zµ%Ω/]*)\s*", value
        )
        if m and m.group(2):
            num, u = m.group(1), m.group(2)
            for p in sorted(_PREFIX, key=len, reverse=True):
                base = u[len(p) :] if p and u.startswith(p) else (u if not p else None)
                if base is not None and _UNIT_ALIASES.get(base) == unit:
                    return exact(name, num) * _PREFIX[p]
            raise ParameterError(
                name,
                value,
                f"expected a value in {unit} (with an optional SI prefix p n u m k M G)",
            )
    return exact(name, value)


@dataclasses.dataclass
class Scene:
    """A validated scene (see the module docstring for the TOML layout).

    See Also
    --------
    precise_impact.scenes.scene.load_scene : parse a scene.
    precise_impact.scenes.run.run_scene : simulate it.
    precise_impact.scenes.scene.builtin_scenes : the shipped scenes.
    """

    name: str
    description: str
    kind: str
    form: str | None
    k: Fraction | None
    model: str
    precision: Precision
    tol: Any
    tmax: Fraction | None
    params: Params
    components: dict
    effects: dict
    periods: int
    per_period: int
    source: str

    def with_model(self, model: str, mp_bits: int | None = None) -> Scene:
        """The same scene with another model (effects re-validated for it; the precision and
        tolerance fitted to it, see :meth:`model_settings`)."""
        return _build(self._fitted_raw(dict(self._raw), model, mp_bits), self.source)

    def _fitted_raw(self, raw: dict, model: str, mp_bits: int | None) -> dict:
        """``raw`` with the ``[model]`` table of :meth:`model_settings` and, for a model
        without dense output (``certified``), ``outputs.per_period = 0``."""
        raw["model"] = self.model_settings(model, mp_bits)
        name = raw["model"]["name"]
        if isinstance(name, str) and name in MODELS and not model_capabilities(name).dense:
            raw["outputs"] = dict(raw.get("outputs", {}), per_period=0)
        return raw

    def model_settings(self, model: str, mp_bits: int | None = None) -> dict:
        """The scene's ``[model]`` table for ``model``: the scene's precision if ``model``
        takes it, else ``mp:BITS`` for a multiprecision-only model (``mp_bits``, default the
        larger of 128 and the scene's bits) or the model's first precision kind; the
        tolerance dropped for a model that takes none; ``tmax`` kept for ``spice`` only."""
        model = MODEL_ALIASES.get(model, model) if isinstance(model, str) else model
        table = dict(self._raw.get("model", {}), name=model)
        if not isinstance(model, str) or model not in MODELS:
            return table  # refused by _model_section, naming model.name
        caps = model_capabilities(model)
        if self.precision.kind not in caps.precisions:
            kind = caps.precisions[0]
            bits = max(128, self.precision.bits) if mp_bits is None else mp_bits
            table["precision"] = f"mp:{bits}" if kind == "mp" else kind
        if not caps.tolerance:
            table.pop("tol", None)
        if model != "spice":
            table.pop("tmax", None)
        return table

    def fitted_to(self, model: str, mp_bits: int | None = None) -> tuple[Scene, list[str]]:
        """The same scene on ``model``, keeping only the effects that fit ``model`` (precision
        and tolerance as :meth:`model_settings`).

        Returns
        -------
        scene : Scene
        dropped : list of str
            The effects that do not fit ``model`` (e.g. the comparator of a
            switched-capacitor scene run on the op-amp ``circuit`` model).
        """

        model = MODEL_ALIASES.get(model, model)
        raw = dict(self._raw)
        eff = dict(raw.get("effects", {}))
        keep = {n: v for n, v in eff.items() if n in EFFECTS and model in EFFECTS[n].models}
        raw = self._fitted_raw(raw, model, mp_bits)
        raw["effects"] = keep
        if model not in CIRCUIT_MODELS:
            raw.pop("components", None)
        return _build(raw, self.source), sorted(set(eff) - set(keep))

    def design(self):
        """Design components (nominal from the parameters, then overrides)."""

        base = nominal_components(
            self.params,
            R=self.components.get("R", "10e3"),
            C=self.components.get("C", "100e-9"),
            V_unit=self.components.get("V_unit", 1),
        )
        over = {n: v for n, v in self.components.items() if n not in ("R", "C", "V_unit")}
        return base.replace(**over) if over else base


def _check_keys(section: str, table: Mapping, allowed: set) -> None:
    for key in table:
        if key not in allowed:
            raise ParameterError(
                f"{section}.{key}" if section else key,
                table[key],
                "unknown key; allowed: " + ", ".join(sorted(allowed)),
            )


def _build(data: Mapping, source: str) -> Scene:
    """The scene of a parsed TOML table, every section validated in turn."""
    if not isinstance(data, Mapping):
        raise ParameterError("scene", source, "a TOML table")
    _check_keys("", data, _TOP)
    for sec, allowed in _SECTIONS.items():
        t = data.get(sec, {})
        if not isinstance(t, Mapping):
            raise ParameterError(sec, t, "a table")
        _check_keys(sec, t, allowed)
    name = data.get("name", Path(source).stem)
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", name):
        raise ParameterError("name", name, "letters, digits, '_', '.', '-'")
    kind, form, k = _system_section(data.get("system", {}))
    model, precision, tol, tmax = _model_section(data.get("model", {}), kind)
    params = _parameters_section(data)
    comps = _components_section(data)
    effects = _effects_section(data, model, kind)
    dur = data.get("duration", {})
    periods = check_count(dur.get("periods", 200), "duration.periods", 10**7)
    per_period = check_count(
        data.get("outputs", {}).get("per_period", 0), "outputs.per_period", 10_000
    )
    scene = Scene(
        name=name,
        description=str(data.get("description", "")),
        kind=kind,
        form=form,
        k=k,
        model=model,
        precision=precision,
        tol=tol,
        tmax=tmax,
        params=params,
        components=comps,
        effects=effects,
        periods=periods,
        per_period=per_period,
        source=source,
    )
    scene._raw = data
    if model in CIRCUIT_MODELS:
        exact_omega(scene.design())  # the design must map exactly onto the dimensionless system
    return scene


def _system_section(system: Mapping):
    """``[system]``: the kind, and for a coupled scene its form and coupling ``k``."""
    kind = system.get("kind", "single")
    if kind not in ("single", "coupled"):
        raise ParameterError("system.kind", kind, "'single' or 'coupled'")
    form = k = None
    if kind == "coupled":
        form = check_form(system.get("form", "first-order"))
        k = check_k(system.get("k", "0.032"), "system.k")
    elif "form" in system or "k" in system:
        raise ParameterError(
            "system.form" if "form" in system else "system.k",
            system.get("form", system.get("k")),
            "only for kind = 'coupled'",
        )
    return kind, form, k


def _model_section(model_t: Mapping, kind: str):
    """``[model]``: the model's name, precision, tolerance and (spice) ``tmax``."""
    model = model_t.get("name", "heyoka")
    model = MODEL_ALIASES.get(model, model) if isinstance(model, str) else model
    if not isinstance(model, str) or model not in MODELS:
        raise ParameterError("model.name", model, "one of " + ", ".join(MODELS))
    if kind == "coupled" and model not in (*COUPLED_MODELS, "circuit"):
        raise ParameterError(
            "model.name",
            model,
            "for a coupled scene one of " + ", ".join((*COUPLED_MODELS, "circuit")),
        )
    precision = Precision.parse(str(model_t.get("precision", "float64")))
    tol = model_t.get("tol")
    precision.check_tol(tol, "model.tol")
    try:
        model_capabilities(model).check(model, precision, tol)
    except ParameterError as e:
        raise ParameterError(f"model.{e.name}", e.value, e.allowed) from None
    tmax = None
    if "tmax" in model_t:
        if model != "spice":
            raise ParameterError("model.tmax", model_t["tmax"], "only for model 'spice'")
        tmax = parse_quantity("model.tmax", model_t["tmax"], "s")
        if not 0 < tmax <= Fraction(1, 1000):
            raise ParameterError("model.tmax", decimal_str(tmax), "0 < tmax <= 1 ms")
    return model, precision, tol, tmax


def _parameters_section(data: Mapping) -> Params:
    """``[parameters]``: the exact system parameters."""
    pt = data.get("parameters", {})
    if not isinstance(pt, Mapping):
        raise ParameterError("parameters", pt, "a table")
    _check_keys("parameters", pt, set(PARAM_NAMES))
    try:
        return Params.make(**dict(pt))
    except ParameterError as e:
        raise ParameterError(f"parameters.{e.name}", e.value, e.allowed) from None


def _components_section(data: Mapping) -> dict[str, Fraction]:
    """``[components]``: the component values (with units), each positive."""
    comps = {
        n: parse_quantity(f"components.{n}", v, COMPONENT_KEYS[n])
        for n, v in data.get("components", {}).items()
    }
    for n, v in comps.items():
        if v <= 0:
            raise ParameterError(f"components.{n}", decimal_str(v), "must be > 0")
    return comps


def _effects_section(data: Mapping, model: str, kind: str) -> dict:
    """``[effects]``: the circuit effects, quantities with units parsed, validated for ``model``."""

    raw_eff = data.get("effects", {})
    if not isinstance(raw_eff, Mapping):
        raise ParameterError("effects", raw_eff, "a table of effect tables")
    if raw_eff and model not in CIRCUIT_MODELS:
        first = next(iter(raw_eff))
        raise ParameterError(
            f"effects.{first}",
            model,
            f"model '{model}' has no circuit effects; use circuit, switched-capacitor or spice",
        )
    eff_in = {en: _effect_quantities(en, settings) for en, settings in raw_eff.items()}
    effects = validate_effects(eff_in, model) if model in CIRCUIT_MODELS else {}
    if kind == "coupled" and model == "circuit":
        bad = sorted(set(effects) - {"tolerance"})
        if bad:
            raise ParameterError(
                f"effects.{bad[0]}",
                "coupled circuit",
                "the coupled circuit model takes only 'tolerance'",
            )
    return effects


def _effect_quantities(en: str, settings: Any) -> Any:
    """One effect's settings with quantities given with units (``'10 ns'``) parsed; an unknown
    effect or a non-table unchanged (the catalogue refuses it)."""

    spec = EFFECTS.get(en)
    if spec is None or not isinstance(settings, Mapping):
        return settings
    conv = {}
    for key, val in settings.items():
        st = spec.settings.get(key)
        if (
            st is not None
            and st.unit not in ("", "int")
            and isinstance(val, str)
            and re.search(r"[a-zA-Zµ%Ω]", val)
        ):
            conv[key] = parse_quantity(f"effects.{en}.{key}", val, st.unit)
        else:
            conv[key] = val
    return conv


def builtin_scenes() -> dict[str, Path]:
    """The scenes shipped in ``precise_impact/scenes``.

    Returns
    -------
    dict of str to Path
        ``{name: path}`` of each built-in ``.toml`` scene.

    See Also
    --------
    precise_impact.scenes.scene.load_scene : parse one of them.
    precise_impact.scenes.run.run_scene : simulate a scene.
    precise_impact.verification.compare.compare : score models on a scene.

    Examples
    --------
    >>> import precise_impact as pi
    >>> "fig6-period3-ideal" in pi.builtin_scenes()
    True
    """
    root = resources.files("precise_impact") / "scenes"
    return {Path(str(p)).stem: Path(str(p)) for p in root.iterdir() if str(p).endswith(".toml")}


def load_scene(spec: str | Path) -> Scene:
    """A built-in scene name or a path to a ``.toml`` file, parsed and validated.

    Parameters
    ----------
    spec : str or Path
        A name from :func:`builtin_scenes` or a path to a regular UTF-8 ``.toml``
        file (at most 1 MiB).

    Returns
    -------
    Scene
        The validated scene (exact parameters, model, precision, effects).

    Raises
    ------
    ParameterError
        Unknown name, unreadable or malformed file, or a value out of range.

    See Also
    --------
    precise_impact.scenes.scene.builtin_scenes : the names accepted.
    precise_impact.scenes.run.run_scene : simulate the scene.
    precise_impact.scenes.scene.Scene : the parsed scene.

    Examples
    --------
    >>> import precise_impact as pi
    >>> sc = pi.load_scene("fig6-period3-ideal")
    >>> type(sc).__name__, str(sc.params.eta)
    ('Scene', '37/50')
    """
    spec = str(spec)
    built = builtin_scenes()
    notice = scene_alias(spec)
    if notice is not None:
        warnings.warn(notice, DeprecationWarning, stacklevel=2)
        spec = SCENE_ALIASES[spec]
    if spec in built:
        path = built[spec]
    else:
        path = Path(spec)
        if path.suffix != ".toml" or not path.exists():
            raise ParameterError(
                "scene",
                spec,
                "a built-in scene name (precise-impact scenes) or an existing .toml file",
            )
    return _build(_read_toml(path), str(path))


#: Largest scene file read (a scene is a few hundred bytes; this refuses a link to an
#: endless device or a huge file before reading it into memory).
MAX_SCENE_BYTES = 1 << 20


def _read_toml(path: Path) -> dict:
    """Parse a scene file: a regular file, at most MAX_SCENE_BYTES, UTF-8, valid TOML."""
    try:
        st = path.stat()  # follows links: a link to /dev/zero is a character device here
    except OSError as e:
        raise ParameterError("scene", str(path), f"a readable .toml file ({e.strerror})") from None
    if not stat.S_ISREG(st.st_mode):
        raise ParameterError(
            "scene", str(path), "a regular .toml file (this is a directory or a device)"
        )
    if st.st_size > MAX_SCENE_BYTES:
        raise ParameterError(
            "scene", str(path), f"a scene file of at most {MAX_SCENE_BYTES} bytes ({st.st_size})"
        )
    try:
        with open(path, "rb") as fh:
            raw = fh.read(MAX_SCENE_BYTES + 1)
        text = raw.decode("utf-8")
    except OSError as e:
        raise ParameterError("scene", str(path), f"a readable .toml file ({e.strerror})") from None
    except UnicodeDecodeError as e:
        raise ParameterError("scene", str(path), f"UTF-8 text (byte {e.start} is not)") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ParameterError("scene", str(path), f"not valid TOML: {e}") from None
