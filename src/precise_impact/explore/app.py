"""One browser session of the explorer (HoloViz Panel on Bokeh): exact-decimal fields with the
CLI's one-line refusals, linked views recomputed in the background, the state in the URL
(``docs/guide/explore.rst``)."""

from __future__ import annotations

import concurrent.futures
import functools
import io
import math
import tempfile
from collections.abc import Callable
from decimal import Decimal
from typing import Any

import panel as pn
from bokeh.events import RangesUpdate, Tap

from precise_impact.core.params import PARAM_NAMES, Params
from precise_impact.errors import ParameterError, PreciseImpactError
from precise_impact.explore import api, figures
from precise_impact.explore.jobs import Cancelled, Runner
from precise_impact.explore.state import CIRCUIT_MODELS, DEFAULTS, ENGINES, UNITS, State
from precise_impact.io.jsonout import dumps
from precise_impact.scenes.scene import builtin_scenes

__all__ = ["Session", "make_session"]

#: Sliders beside these fields: (start, end, step).
SLIDERS = {"eta": (0.3, 3.0, 0.001), "zeta": (0.0, 0.5, 0.001), "x_w": (-1.0, 4.0, 0.01),
           "R": (0.0, 1.0, 0.01), "a": (0.0, 3.0, 0.01)}  # fmt: skip
#: The fields of the form: the parameters, then the run's settings.
FIELDS = (*PARAM_NAMES, "model", "precision", "periods", "transient", "units")


class Session:
    """The page of one browser session (see the module docstring)."""

    def __init__(
        self,
        executor: concurrent.futures.Executor,
        doc: Any = None,
        query: dict[str, str] | None = None,
        location: Any = None,
        dask: str | None = None,
    ) -> None:
        schedule = doc.add_next_tick_callback if doc is not None else (lambda cb: cb())
        views = ("orbit", "lle", "bif", "proof", "basins", "impacts", *CIRCUIT_MODELS)
        self.runners = {v: Runner(executor, schedule) for v in views}
        self.schedule = schedule
        self.location, self.dask = location, dask
        self.inputs, self.errors = self._form(query or {})
        self.info = pn.pane.Markdown("", css_classes=["pi-orbit-info"], width=420)
        self.loading = False
        self.command = pn.widgets.TextAreaInput(
            name="copy as command / as Python", value="", height=140, width=620, disabled=True
        )
        self.orbit = figures.orbit_figures()
        self.bif = figures.bifurcation_figures()
        self.proof = figures.proof_figure()
        self.proof_info = pn.pane.Markdown("", css_classes=["pi-proof-info"])
        self.bif_info = pn.pane.Markdown("", css_classes=["pi-bif-info"])
        self.basins_info = pn.pane.Markdown("", css_classes=["pi-basins-info"])
        self.basins = figures.basins_figure(60, 40, 4.0)
        self.impacts = figures.impact_figure()
        self.impacts_info = pn.pane.Markdown("", css_classes=["pi-impacts-info"])
        self.circuit_info = pn.pane.Markdown("", css_classes=["pi-circuit-info"])
        self.last: dict[str, Any] = {}
        self.summary, self.lle_line = "", ""
        self._wire()

    # ---------------------------------------------------------------- the form
    def _form(self, query: dict[str, str]) -> tuple[dict[str, Any], dict[str, Any]]:
        """Text fields (and sliders) for the state, each with an error line under it; the
        values ``query`` gives (a permalink's), the defaults elsewhere."""
        p = {**Params.make().decimal(), **DEFAULTS, **query}
        inputs: dict[str, Any] = {}
        for name in PARAM_NAMES:
            inputs[name] = pn.widgets.TextInput(name=name, value=p[name], width=150,
                                                css_classes=[f"pi-field-{name}"])  # fmt: skip
        inputs["model"] = pn.widgets.Select(name="engine", options=list(ENGINES), value=p["model"],
                                            css_classes=["pi-field-model"], width=150)  # fmt: skip
        for name in ("precision", "periods", "transient"):
            inputs[name] = pn.widgets.TextInput(name=name, value=p[name], width=150,
                                                css_classes=[f"pi-field-{name}"])  # fmt: skip
        inputs["units"] = pn.widgets.RadioButtonGroup(options=list(UNITS), value=p["units"],
                                                      css_classes=["pi-field-units"])  # fmt: skip
        errors = {n: pn.pane.Str("", css_classes=[f"pi-error-{n}"], styles={"color": "#b00020"})
                  for n in FIELDS}  # fmt: skip
        return inputs, errors

    def _sliders(self) -> dict[str, Any]:
        """A slider beside each main parameter's text field, kept in step with it."""
        out = {}
        for name, (lo, hi, step) in SLIDERS.items():
            s = pn.widgets.FloatSlider(start=lo, end=hi, step=step, width=150,
                                       value=float(self.inputs[name].value))  # fmt: skip
            s.param.watch(functools.partial(self._slid, name), "value_throttled")
            self.inputs[name].param.watch(functools.partial(self._typed, s), "value")
            out[name] = s
        return out

    def _scene_widgets(self) -> list[Any]:
        """A built-in scene to pick, or a scene file (``.toml``) to load, and its error line."""
        self.scene = pn.widgets.Select(name="scene", options=["", *builtin_scenes()], value="",
                                       css_classes=["pi-scene"], width=220)  # fmt: skip
        self.scene_file = pn.widgets.FileInput(accept=".toml", css_classes=["pi-scene-file"])
        self.scene_error = pn.pane.Str("", css_classes=["pi-error-scene"],
                                       styles={"color": "#b00020"})  # fmt: skip
        self.scene.param.watch(lambda e: e.new and self.load_scene(e.new), "value")
        self.scene_file.param.watch(lambda e: e.new and self._scene_uploaded(e.new), "value")
        return [self.scene, self.scene_file, self.scene_error]

    def _scene_uploaded(self, data: bytes) -> None:
        with tempfile.TemporaryDirectory() as d:
            path = f"{d}/{self.scene_file.filename or 'scene.toml'}"
            with open(path, "wb") as f:
                f.write(data)
            self.load_scene(path)

    def load_scene(self, spec: str) -> None:
        """The fields set from a scene (one recomputation, not one per field); a refused scene
        shows its line under the scene's field and changes nothing."""
        self.scene_error.object = ""
        try:
            st = State.from_scene(spec, {n: str(w.value) for n, w in self.inputs.items()})
        except ParameterError as e:
            self.scene_error.object = str(e)
            return
        self.loading = True
        try:
            for name, value in st.to_query().items():
                if name in self.inputs:
                    self.inputs[name].value = value
        finally:
            self.loading = False
        self.refresh()

    def _typed(self, slider: Any, event: Any) -> None:
        """A typed value moves its slider (within the slider's range; the text stays exact)."""
        try:
            x = float(event.new)
        except ValueError:
            return
        if slider.start <= x <= slider.end and slider.value != x:
            slider.value = x

    def _slid(self, name: str, event: Any) -> None:
        self.inputs[name].value = str(Decimal(repr(event.new)).normalize())

    # ---------------------------------------------------------------- wiring
    def _on_loop(self, handler: Callable[[], None]) -> Callable[..., None]:
        """``handler`` as a widget callback that runs on the session's next tick, holding the
        document lock: Panel >= 1.9 runs a button's click in a coroutine without it, where
        writing a Bokeh model (a figure's data) raises (seen with panel 1.9.4, bokeh 3.9.2)."""
        return lambda *event: self.schedule(handler)

    def _wire(self) -> None:
        self.sliders = self._sliders()
        for w in self.inputs.values():
            w.param.watch(lambda e: self.loading or self.refresh(), "value")
        for fig in (self.bif["diagram"], self.bif["lle"]):
            fig.on_event(Tap, self._tapped)
        self.bif["diagram"].on_event(RangesUpdate, self._zoomed)
        self.bif_button = pn.widgets.Button(name="recompute the diagram", button_type="primary",
                                            css_classes=["pi-bif-run"])  # fmt: skip
        self.bif_button.on_click(self._on_loop(self.run_bifurcation))
        self.prove_period = pn.widgets.IntInput(
            name="orbit period", value=1, start=1, end=64, width=120,
            css_classes=["pi-prove-period"],
        )  # fmt: skip
        self.prove_button = pn.widgets.Button(name="prove the orbit (Krawczyk)",
                                              css_classes=["pi-prove-run"])  # fmt: skip
        self.prove_button.on_click(self._on_loop(self.run_proof))
        self.certify_button = pn.widgets.Button(name="certify 100 periods (balls)",
                                                css_classes=["pi-certify-run"])  # fmt: skip
        self.certify_button.on_click(self._on_loop(self.run_certified))
        self._basins_widgets()
        self.overlay = pn.widgets.Checkbox(name="overlay the circuit models", value=False,
                                           css_classes=["pi-overlay"])  # fmt: skip
        self.overlay.param.watch(self._on_loop(self.run_circuits), "value")
        self.impacts_button = pn.widgets.Button(
            name="impact map + singularity set", css_classes=["pi-impacts-run"]
        )
        self.impacts_button.on_click(self._on_loop(self.run_impacts))
        self.download = pn.widgets.FileDownload(
            callback=self._orbit_json, filename="orbit.json", label="orbit as JSON",
            css_classes=["pi-download-json"],
        )  # fmt: skip
        self.downloads = {v: self._downloads(v) for v in ("orbit", "bifurcation", "impact-map",
                                                           "basins")}  # fmt: skip

    def state(self) -> State | None:
        """The form's state, or ``None`` with the refused field's message under it."""
        for pane in self.errors.values():
            pane.object = ""
        query = {n: str(w.value) for n, w in self.inputs.items()}
        try:
            return State.from_query(query)
        except ParameterError as e:
            pane = self.errors.get(e.name) or self.errors["eta"]
            pane.object = str(e)
            return None

    def refresh(self) -> None:
        """A new state: recompute the orbit and its LLE (the diagram keeps its range)."""
        st = self.state()
        if st is None:
            return
        self.summary, self.lle_line = "computing ...", ""
        self._show_info()
        if self.location is not None:  # the URL holds the state: a link reopens it
            self.location.update_query(**{n: str(w.value) for n, w in self.inputs.items()})
        work = lambda flag: api.orbit(st, full=False)  # noqa: E731
        self.runners["orbit"].start(work, self._orbit_done, self._failed)
        self.runners["lle"].start(lambda flag: api.lle(st), self._lle_done, self._failed)

    def _orbit_done(self, got: dict[str, Any]) -> None:
        self.last["orbit"] = got
        units = figures.show_orbit(self.orbit, got, str(self.inputs["units"].value))
        d = got["digits"]
        self.summary = (
            f"**period** {got['period'] or 'none found'} &nbsp; "
            f"**impacts per period** {got['impacts_per_period']:.4g} &nbsp; "
            f"**digits claimed** {d['min']}-{d['max_possible']} ({d['basis']}) &nbsp; "
            f"**axes** {units} &nbsp; **eta** {got['state']['eta']}"
        )
        self._show_info()
        self.command.value = f"{got['command']}\n\n{got['python']}"
        self.run_circuits()

    # ---------------------------------------------------------------- circuit models
    def run_circuits(self) -> None:
        """The circuit models' orbits over the mechanics' (when the box is ticked), each in
        its own run: the op-amp circuit takes seconds, the switched-capacitor one ~0.1 s."""
        st = self.state()
        if st is None or "orbit" not in self.last:
            return
        if not self.overlay.value:
            for model in CIRCUIT_MODELS:
                self.runners[model].cancel()
                self.orbit["sources"][model].data = {"t": [], "x": [], "v": []}
            self.circuit_info.object = ""
            return
        self.circuit_lines: dict[str, str] = {}
        self.circuit_info.object = "computing the circuit models ..."
        for model in CIRCUIT_MODELS:
            work = functools.partial(lambda m, flag: api.circuit(st, m), model)
            self.runners[model].start(work, self._circuit_done, self._failed)

    def _circuit_done(self, got: dict[str, Any]) -> None:
        if got["state"] != self.last["orbit"]["state"]:
            return  # another orbit is shown by now
        figures.show_circuit(self.orbit, got)
        self.circuit_lines[got["model"]] = (
            f"**{got['model']}**: max |x - x_mechanics| on the strobe {got['max_dx_shown']:.3g}"
        )
        self.circuit_info.object = " &nbsp; ".join(self.circuit_lines.values())

    def _lle_done(self, got: dict[str, Any]) -> None:
        self.lle_line = (
            f" &nbsp; **LLE** {got['lle']:.6g} +- {got['stderr']:.2g} (eta {got['state']['eta']})"
        )
        self._show_info()

    def _show_info(self) -> None:
        """The orbit's line and its LLE (each as its own run finished; the LLE names its eta,
        so a line never pairs one state's orbit with another's exponent)."""
        self.info.object = self.summary + self.lle_line

    def _failed(self, error: BaseException) -> None:
        text = " ".join(str(error).splitlines())
        self.info.object = f"**{type(error).__name__}**: {text}"
        if not isinstance(error, PreciseImpactError):
            raise error

    def _downloads(self, view: str) -> list[Any]:
        """The view's last numbers as CSV, and (but the orbit's, which is the CLI's ``--json``
        above) as the view's strict JSON."""
        out = [pn.widgets.FileDownload(
            callback=functools.partial(self._view_text, view, "csv"), filename=f"{view}.csv",
            label=f"{view} as CSV", css_classes=[f"pi-download-{view}-csv"],
        )]  # fmt: skip
        if view != "orbit":
            out.append(pn.widgets.FileDownload(
                callback=functools.partial(self._view_text, view, "json"),
                filename=f"{view}.json", label=f"{view} as JSON",
                css_classes=[f"pi-download-{view}-json"],
            ))  # fmt: skip
        return out

    def _view_text(self, view: str, kind: str) -> io.StringIO:
        got = self.last.get(view)
        if got is None:
            return io.StringIO("")
        return io.StringIO(api.view_csv(got) if kind == "csv" else dumps(got))

    def _orbit_json(self):
        got = self.last.get("orbit")
        st = State.from_query(got["state"]) if got else (self.state() or State.from_query({}))
        return io.StringIO(dumps(api.orbit(st)["result"]))

    # ---------------------------------------------------------------- diagram
    def run_bifurcation(self) -> None:
        st = self.state()
        if st is None:
            return
        self.bif_info.object = "computing ..."
        self.runners["bif"].start(lambda flag: api.bifurcation(st), self._bif_done, self._failed)

    def _bif_done(self, got: dict[str, Any]) -> None:
        self.last["bifurcation"] = got
        self._showing_bif = True
        figures.show_bifurcation(self.bif, got)
        self._showing_bif = False
        eta = got["eta"]
        self.bif_info.object = (
            f"{len(eta)} values of eta in [{got['state']['eta_min']}, {got['state']['eta_max']}], "
            f"{got['state']['bif_periods']} periods each after {got['state']['bif_transient']}"
        )

    def _zoomed(self, event: Any) -> None:
        """A drag zoomed the diagram: recompute it at the new resolution over the new range
        (not when the figure's own update moved the range)."""
        if getattr(self, "_showing_bif", False) or event.x0 is None or event.x1 is None:
            return
        if event.x1 <= event.x0 or event.x0 <= 0:
            return
        lo, hi = (str(Decimal(repr(round(x, 6))).normalize()) for x in (event.x0, event.x1))
        self.run_bifurcation_range(lo, hi)

    def run_bifurcation_range(self, lo: str, hi: str) -> None:
        st = self.state()
        if st is None:
            return
        try:
            st = State.from_query({**st.to_query(), "eta_min": lo, "eta_max": hi})
        except ParameterError:
            return
        self.bif_info.object = f"computing [{lo}, {hi}] ..."
        self.runners["bif"].start(lambda flag: api.bifurcation(st), self._bif_done, self._failed)

    def _tapped(self, event: Any) -> None:
        if event.x is not None and event.x > 0:
            self.inputs["eta"].value = str(Decimal(repr(round(event.x, 6))).normalize())

    # ---------------------------------------------------------------- basins
    def _basins_widgets(self) -> None:
        self.basins_n = pn.widgets.IntInput(name="cells per side", value=40, start=4, end=400,
                                            width=120, css_classes=["pi-basins-n"])  # fmt: skip
        self.basins_run = pn.widgets.Button(name="compute the map", button_type="primary",
                                            css_classes=["pi-basins-run"])  # fmt: skip
        self.basins_stop = pn.widgets.Button(name="cancel", css_classes=["pi-basins-cancel"])
        self.basins_run.on_click(self._on_loop(self.run_basins))
        self.basins_stop.on_click(self._on_loop(self.cancel_basins))
        self.basins["figure"].on_event(Tap, self._cell_tapped)

    def run_basins(self) -> None:
        """The map on the impact surface, drawn row by row as the rows finish."""
        st = self.state()
        if st is None:
            return
        n = int(self.basins_n.value)
        fig = figures.basins_figure(n, n, 4.0)
        self.basins["source"].data = dict(fig["source"].data)
        self.basins.update(shape=fig["shape"])
        done = [0]

        def work(flag):
            def row(tile):
                if flag.is_set():
                    raise Cancelled
                self.schedule(lambda: self._basins_row(tile, done, n))

            return api.basins(st, n, n, 4.0, on_tile=row, dask=self.dask)

        self.basins_info.object = f"computing {n} x {n} cells ..."
        self.runners["basins"].start(work, self._basins_done, self._failed)

    def _basins_row(self, tile: dict, done: list, n: int) -> None:
        if not self.runners["basins"].running:
            return
        figures.show_basins_tile(self.basins, tile)
        done[0] += 1
        self.basins_info.object = f"rows {done[0]} / {n}"

    def _basins_done(self, got: dict[str, Any]) -> None:
        self.last["basins"] = got
        kinds = ", ".join(f"{a.get('name', a.get('kind'))}" for a in got["attractors"] or [])
        self.basins_info.object = f"done: {len(got['labels'])} rows; attractors: {kinds}"

    def cancel_basins(self) -> None:
        self.runners["basins"].cancel()
        self.basins_info.object = "cancelled (the rows drawn are kept)"

    def _cell_tapped(self, event: Any) -> None:
        """A cell's orbit: leaving the wall at its impact phase with speed R v."""
        st = self.state()
        if st is None or event.x is None or event.y is None or event.y <= 0:
            return
        p = st.params
        t0 = event.x * 2 * 3.141592653589793 / float(p.eta)
        self.inputs["x0"].value = p.decimal()["x_w"]
        self.inputs["v0"].value = _short(-float(p.R) * event.y)
        self.inputs["t0"].value = _short(t0)

    # ---------------------------------------------------------------- impact map
    def run_impacts(self) -> None:
        """The impact map from the orbit's last impact (on its attractor; from phase 0.3,
        speed 1 when it has none), 2000 impacts, with the singularity set."""
        st = self.state()
        if st is None:
            return
        phase, v = 0.3, 1.0
        imp = self.last.get("orbit", {}).get("impacts", {"t": []})
        if imp["t"] and imp["t"][-1] is not None:
            eta = float(st.params.eta)
            phase = (imp["t"][-1] * eta / (2 * math.pi)) % 1.0
            v = max(abs(imp["v"][-1]), 1e-6)  # the incoming speed, as the map takes it
        self.impacts_info.object = "computing 2000 impacts and the singularity set ..."
        work = lambda flag: api.impact_map(st, phase, v, 2000, singularity=True)  # noqa: E731
        self.runners["impacts"].start(work, self._impacts_done, self._failed)

    def _impacts_done(self, got: dict[str, Any]) -> None:
        self.last["impact-map"] = got
        figures.show_impacts(self.impacts, got)
        kinds = {k: got["kind"].count(k) for k in ("impact", "chatter", "sticking")}
        self.impacts_info.object = (
            f"{len(got['phase'])} events ({', '.join(f'{k} {n}' for k, n in kinds.items())}) from "
            f"phase {got['args']['phase']:.4f}, v {got['args']['v']:.4f}; "
            f"{len(got['singularity'])} singularity curves"
        )

    # ---------------------------------------------------------------- proof
    def run_proof(self) -> None:
        st = self.state()
        if st is None:
            return
        period = int(self.prove_period.value)
        self.proof_info.object = "proving ..."
        work = lambda flag: api.proof(st, period)  # noqa: E731
        self.runners["proof"].start(work, self._proof_done, self._proof_failed)

    def run_certified(self) -> None:
        st = self.state()
        if st is None:
            return
        self.proof_info.object = "certifying ..."
        work = lambda flag: api.certified(st, 100)  # noqa: E731
        self.runners["proof"].start(work, self._certified_done, self._proof_failed)

    def _certified_done(self, got: dict[str, Any]) -> None:
        figures.show_certified(self.proof, got)
        self.proof_info.object = (
            f"**certified** 100 periods at {got['bits']} bits: the radius grows "
            f"{got['growth_digits_per_period']:.3g} decimal digits per period, last "
            f"10^{got['log10_radius'][-1]:.1f}"
        )

    def _proof_done(self, got: dict[str, Any]) -> None:
        r = got["result"]
        self.proof_info.object = (
            f"**proven**: {r['proven']}, stable: {r.get('stable')}, {r['bits']} bits; "
            f"x = {r['x'][0][:24]} +- {r['x'][1]}"
        )

    def _proof_failed(self, error: BaseException) -> None:
        self.proof_info.object = f"**not proven**: {' '.join(str(error).splitlines())}"

    # ---------------------------------------------------------------- layout
    def layout(self) -> Any:
        rows = []
        for n in FIELDS:
            row = [self.inputs[n]] + ([self.sliders[n]] if n in self.sliders else [])
            rows.append(pn.Column(pn.Row(*row), self.errors[n], margin=0))
        form = pn.Column("## parameters (exact decimals)", *self._scene_widgets(), *rows,
                         width=360)  # fmt: skip
        orbit = pn.Column(self.info, pn.Row(self.overlay, self.circuit_info),
                          pn.Row(self.orbit["phase"], self.orbit["xt"]),
                          pn.Row(self.command,
                                 pn.Column(self.download, *self.downloads["orbit"])))  # fmt: skip
        diagram = pn.pane.Bokeh(self.bif["diagram"], css_classes=["pi-bif-diagram"])
        bif = pn.Column(pn.Row(self.bif_button, self.bif_info, *self.downloads["bifurcation"]),
                        diagram, self.bif["lle"])  # fmt: skip
        proof = pn.Column(pn.Row(self.prove_period, self.prove_button, self.certify_button),
                          self.proof_info,
                          self.proof["figure"])  # fmt: skip
        basins = pn.Column(
            pn.Row(self.impacts_button, self.basins_n, self.basins_run, self.basins_stop),
            pn.Row(self.impacts_info, *self.downloads["impact-map"]),
            pn.Row(self.basins_info, *self.downloads["basins"]),
            pn.Row(pn.pane.Bokeh(self.impacts["figure"], css_classes=["pi-impact-map"]),
                   pn.pane.Bokeh(self.basins["figure"], css_classes=["pi-basins-map"])),
        )  # fmt: skip
        tabs = pn.Tabs(("orbit", orbit), ("bifurcation", bif), ("impact surface", basins),
                       ("proof", proof), dynamic=False)  # fmt: skip
        return pn.Row(form, tabs)


def make_session(executor: concurrent.futures.Executor, dask: str | None = None) -> Any:
    """The page for a new browser session, from the URL's query string (a permalink); its
    domains of attraction run on the Dask scheduler ``dask`` when one is given."""
    args = pn.state.session_args or {}
    query = {k: v[0].decode() for k, v in args.items() if k in FIELDS and v}
    session = Session(executor, pn.state.curdoc, query, pn.state.location, dask)
    session.refresh()
    return session.layout()


def _short(x: float) -> str:
    """A float as a short exact decimal (7 significant digits: a cell's centre, not more)."""
    return str(Decimal(f"{x:.7g}").normalize())
