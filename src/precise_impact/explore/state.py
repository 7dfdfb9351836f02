"""What the explorer shows, as one value: exact parameters, engine, run length and view settings;
it round-trips through a URL query string and renders as the CLI and Python calls of each view
(``docs/guide/explore.rst``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

from precise_impact.core.params import PARAM_NAMES, Params, check_count
from precise_impact.core.precision import Precision
from precise_impact.errors import ParameterError
from precise_impact.scenes.scene import load_scene

__all__ = ["CIRCUIT_MODELS", "DEFAULTS", "DENSE_PER_PERIOD", "ENGINES", "State", "UNITS", "VIEWS"]

#: The engines the orbit view runs: the compiled closed forms or heyoka's Taylor integrator.
ENGINES = ("fast", "heyoka")
#: The orbit view's axes: the mechanics' dimensionless units or the circuit's volts and seconds.
UNITS = ("mechanical", "circuit")
#: Points per forcing period of the orbit view's curves (phase portrait, x(t)): the run is made
#: with them (the compiled engine's samples then round as the command's ``--dense`` run does).
DENSE_PER_PERIOD = 64
#: The views, each one computation of :mod:`precise_impact.explore.api`.
VIEWS = ("orbit", "lle", "circuit", "bifurcation", "impact-map", "basins", "proof", "certified")
#: The circuit models the orbit view overlays on the mechanics (the ``circuit`` view's ``model``).
CIRCUIT_MODELS = ("circuit", "switched-capacitor")

_INTS = {
    "periods": 10**6,
    "transient": 10**7,
    "n": 2000,
    "bif_periods": 10**5,
    "bif_transient": 10**6,
}
DEFAULTS: dict[str, str] = {
    "model": "fast",
    "precision": "float64",
    "periods": "200",
    "transient": "0",
    "eta_min": "0.68",
    "eta_max": "0.82",
    "n": "400",
    "bif_periods": "300",
    "bif_transient": "300",
    "units": "mechanical",
}


@dataclasses.dataclass(frozen=True)
class State:
    """The explorer's state (see the module docstring).

    Attributes
    ----------
    params : Params
        The system and its start, exact.
    model : {'fast', 'heyoka'}
        The orbit view's engine.
    precision : str
        ``float64`` for the compiled engine; any of the package's precisions for heyoka.
    periods, transient : int
        Forcing periods shown and skipped before them.
    eta_min, eta_max : str
        The bifurcation diagram's range (exact decimals); ``n`` values of eta, each run
        ``bif_transient`` periods before ``bif_periods`` are drawn.
    units : {'mechanical', 'circuit'}
        The orbit view's axes.
    """

    params: Params
    model: str = "fast"
    precision: str = "float64"
    periods: int = 200
    transient: int = 0
    eta_min: str = "0.68"
    eta_max: str = "0.82"
    n: int = 400
    bif_periods: int = 300
    bif_transient: int = 300
    units: str = "mechanical"

    @classmethod
    def from_query(cls, query: Mapping[str, Any]) -> State:
        """The state a query string's fields give (missing fields: the defaults); a field
        the explorer does not know, or a value out of range, is refused naming it."""
        unknown = sorted(set(query) - set(PARAM_NAMES) - set(DEFAULTS) - {"view"})
        if unknown:
            allowed = ", ".join((*PARAM_NAMES, *DEFAULTS))
            raise ParameterError(unknown[0], query[unknown[0]], f"one of the fields {allowed}")
        params = Params.make(**{k: query[k] for k in PARAM_NAMES if k in query})
        got = {k: query.get(k, d) for k, d in DEFAULTS.items()}
        return cls(params=params, **_checked(got))

    @classmethod
    def from_scene(cls, spec: Any, query: Mapping[str, Any] | None = None) -> State:
        """The state a scene gives (a built-in name or a ``.toml`` path, as ``run`` takes it):
        its parameters and start, its periods, its engine where the explorer has it; the other
        fields from ``query``.  A bad scene is refused in one line (``ParameterError``)."""
        scene = load_scene(spec)
        fields = {**dict(query or {}), **scene.params.decimal(), "periods": str(scene.periods)}
        if scene.model in ENGINES:
            fields["model"] = scene.model
            fields["precision"] = scene.precision.name
        return cls.from_query(fields)

    def to_query(self) -> dict[str, str]:
        """Every field as text (the parameters as exact decimals): ``from_query`` of it gives
        this state back."""
        out = dict(self.params.decimal())
        for f in DEFAULTS:
            out[f] = str(getattr(self, f))
        return out

    def command(self, view: str = "orbit", **args: Any) -> str | None:
        """The ``precise-impact`` call that computes the view's numbers (``--json`` where the
        command has it), or ``None`` where no command does (the proof: Python only)."""
        words = _cli_words(self, view, args)
        return None if words is None else "precise-impact " + " ".join(words)

    def python(self, view: str = "orbit", **args: Any) -> str:
        """The Python call that returns the view's result (its ``to_dict()`` is the command's
        ``--json``)."""
        fields = ", ".join(f"{k}={v!r}" for k, v in self.params.decimal().items())
        head = f"import precise_impact as pi\n\np = pi.Params.make({fields})\n"
        return head + _api_call(self, view, args)


def _checked(got: dict[str, Any]) -> dict[str, Any]:
    """The non-parameter fields, checked and typed (each refused naming itself)."""
    if got["model"] not in ENGINES:
        raise ParameterError("model", got["model"], "one of " + ", ".join(ENGINES))
    if got["units"] not in UNITS:
        raise ParameterError("units", got["units"], "one of " + ", ".join(UNITS))
    prec = Precision.parse(got["precision"]).name  # refused naming precision
    if got["model"] == "fast" and prec != "float64":
        raise ParameterError("precision", got["precision"], "float64 with model = fast")
    out = dict(got, precision=prec)
    for name, top in _INTS.items():
        out[name] = check_count(got[name], name, top, minimum=0 if "transient" in name else 1)
    for name in ("eta_min", "eta_max"):
        out[name] = Params.make(eta=got[name]).decimal()["eta"]  # exact, > 0
    if Params.make(eta=out["eta_min"]).eta >= Params.make(eta=out["eta_max"]).eta:
        raise ParameterError("eta_max", got["eta_max"], f"> eta_min = {out['eta_min']}")
    return out


def _param_flags(state: State, skip: tuple[str, ...] = ()) -> list[str]:
    """``--NAME VALUE`` for every parameter but ``skip``, exact decimals."""
    return [w for k, v in state.params.decimal().items() if k not in skip for w in (f"--{k}", v)]


def _cli_words(state: State, view: str, args: dict[str, Any]) -> list[str] | None:
    """The command line's words for ``view``, or ``None`` (no command computes it)."""
    p = _param_flags(state)
    if view == "orbit":
        words = ["simulate", *p, "--model", state.model, "--precision", state.precision]
        n = str(state.transient + state.periods)
        return [*words, "--periods", n, "--dense", str(DENSE_PER_PERIOD), "--json"]
    if view == "lle":
        return ["lle", *p, "--model", "fast", "--json"]
    if view == "circuit":
        n = str(state.transient + state.periods)
        words = ["simulate", *p, "--model", args["model"], "--periods", n]
        return [*words, "--dense", str(DENSE_PER_PERIOD), "--json"]
    if view == "bifurcation":
        rng = ["--eta", state.eta_min, state.eta_max, str(state.n), *_param_flags(state, ("eta",))]
        runs = ["--periods", str(state.bif_periods), "--transient", str(state.bif_transient)]
        return ["bifurcation", *rng, *runs, "--out", "bifurcation"]
    if view == "impact-map":
        at = ["--phase", repr(args["phase"]), "--v", repr(args["v"]), "--n", str(args["n"])]
        sing = ["--singularity", "--out", "impact"] if args.get("singularity") else []
        return ["impact-map", *p, *at, "--engine", "fast", "--transient", "0", *sing, "--json"]
    if view == "basins":
        v_lo = args["v_max"] / (2 * args["n_v"])
        grid = ["--phase", "0", "1", str(args["n_phase"]), "--v", repr(v_lo), repr(args["v_max"])]
        t = ["--transient", str(max(state.transient, 100)), "--tile", str(args["n_phase"])]
        return ["basins", *p, *grid, str(args["n_v"]), *t, "--out", "basins"]
    if view == "certified":
        return ["certify", *p, "--periods", str(args["periods"]), "--target", "1e-30"]
    if view == "proof":
        return None
    raise ParameterError("view", view, "one of " + ", ".join(VIEWS))


def _api_call(state: State, view: str, args: dict[str, Any]) -> str:
    """The Python lines for ``view`` after ``p`` is made."""
    calls = {
        "orbit": lambda: (
            f"pi.simulate(p, {state.transient + state.periods}, "
            f"model={state.model!r}, precision={state.precision!r}, per_period={DENSE_PER_PERIOD})"
        ),
        "lle": lambda: "pi.lyapunov(p, model='fast')",
        "circuit": lambda: (
            f"pi.simulate(p, {state.transient + state.periods}, model={args.get('model')!r}, "
            f"per_period={DENSE_PER_PERIOD})"
        ),
        "bifurcation": lambda: (
            f"pi.bifurcation(p, {('eta', state.eta_min, state.eta_max, state.n)!r}, "
            f"periods={state.bif_periods}, transient={state.bif_transient})"
        ),
        "impact-map": lambda: (
            f"pi.impact_map(p, {args['phase']!r}, {args['v']!r}, {args['n']}, engine='fast')"
            + ("\ns = pi.singularity_set(p)" if args.get("singularity") else "")
        ),
        "proof": lambda: f"pi.prove_orbit(p, {args['period']}, transient={args['transient']})",
        "certified": lambda: f"pi.certify(p, {args['periods']})",
        "basins": lambda: (
            f"pi.basins(p, ((0.0, 1.0, {args['n_phase']}), "
            f"({args['v_max'] / (2 * args['n_v'])!r}, {args['v_max']!r}, {args['n_v']})), "
            f"transient={max(state.transient, 100)}, tile_size={args['n_phase']})"
        ),
    }
    if view not in calls:
        raise ParameterError("view", view, "one of " + ", ".join(VIEWS))
    return f"r = {calls[view]()}\n"
