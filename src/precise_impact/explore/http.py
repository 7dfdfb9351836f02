"""The explorer's JSON API: ``GET /api/<view>?<fields>`` answers the view's dict as strict JSON
(400 naming a refused field, 404 for no such view; ``GET /api``: the schema), computed on a
thread pool, never on the event loop (``docs/guide/explore.rst``)."""

from __future__ import annotations

import asyncio
import concurrent.futures
import math
from typing import Any

from tornado.web import RequestHandler

from precise_impact.core.params import PARAM_NAMES, check_count
from precise_impact.errors import ParameterError, PreciseImpactError
from precise_impact.explore.api import VIEW_FUNCTIONS, run_view
from precise_impact.explore.state import DEFAULTS, ENGINES, UNITS, State
from precise_impact.io.jsonout import dumps

__all__ = ["ApiHandler", "SCHEMA", "api_patterns", "view_arguments"]

#: Each view's own arguments: name -> (type, default or None when required, meaning).
ARGUMENTS: dict[str, dict[str, tuple[str, Any, str]]] = {
    "orbit": {},
    "lle": {},
    "circuit": {"model": ("string", "circuit", "one of circuit, switched-capacitor")},
    "bifurcation": {},
    "impact-map": {
        "phase": ("number", 0.3, "forcing phase of the first impact, in [0, 1)"),
        "v": ("number", 1.0, "speed leaving the wall, > 0"),
        "n": ("integer", 200, "impacts, 1 .. 100000"),
        "singularity": ("boolean", False, "true: the map's singularity set too"),
    },
    "proof": {"period": ("integer", 1, "forcing periods of the orbit, 1 .. 64")},
    "certified": {"periods": ("integer", 100, "forcing periods certified, 1 .. 3000")},
    "basins": {
        "n_phase": ("integer", 60, "columns: impact phases in [0, 1), 1 .. 1000"),
        "n_v": ("integer", 40, "rows: incoming speeds in (0, v_max], 1 .. 1000"),
        "v_max": ("number", 4.0, "largest incoming speed, > 0"),
    },
}
#: Largest value of each integer argument.
INTEGER_MAX = {"period": 64, "n": 100_000, "n_phase": 1000, "n_v": 1000, "periods": 3000}

#: What ``GET /api`` answers: the views, their arguments, the state's fields.
SCHEMA: dict[str, Any] = {
    "views": {
        view: {name: {"type": t, "default": d, "meaning": m} for name, (t, d, m) in a.items()}
        for view, a in ARGUMENTS.items()
    },
    "state": {
        "parameters": list(PARAM_NAMES),
        "fields": dict(DEFAULTS),
        "model": list(ENGINES),
        "units": list(UNITS),
    },
    "errors": {"400": {"error": "one line", "parameter": "its name"}, "404": "no such view"},
}


def view_arguments(view: str, query: dict[str, str]) -> dict[str, Any]:
    """The view's own arguments from the query (defaults for the missing ones), checked."""
    out: dict[str, Any] = {}
    for name, (kind, default, meaning) in ARGUMENTS[view].items():
        raw = query.get(name, default)
        if kind == "string":
            out[name] = str(raw)
            continue
        if kind == "boolean":
            if str(raw).lower() not in ("true", "false", "1", "0"):
                raise ParameterError(name, raw, "true or false")
            out[name] = str(raw).lower() in ("true", "1")
            continue
        if kind == "integer":
            out[name] = check_count(raw, name, INTEGER_MAX[name], minimum=1)
            continue
        try:
            out[name] = float(raw)
        except (TypeError, ValueError):
            raise ParameterError(name, raw, meaning) from None
        if not math.isfinite(out[name]) or (name != "phase" and out[name] <= 0):
            raise ParameterError(name, raw, meaning)
        if name == "phase" and not 0 <= out[name] < 1:
            raise ParameterError(name, raw, meaning)
    return out


class ApiHandler(RequestHandler):
    """``GET /api/<view>``: the view's dict, or a one-line error (see the module docstring)."""

    executor: concurrent.futures.Executor

    def initialize(self, executor: concurrent.futures.Executor) -> None:
        self.executor = executor

    async def get(self, view: str = "") -> None:
        self.set_header("Content-Type", "application/json; charset=utf-8")
        if not view:
            return self.finish(dumps(SCHEMA))
        if view not in VIEW_FUNCTIONS:
            self.set_status(404)
            return self.finish(dumps({"error": f"no view {view!r}", "views": list(ARGUMENTS)}))
        query = {k: self.get_argument(k) for k in self.request.arguments}
        try:
            state = State.from_query({k: v for k, v in query.items() if k not in ARGUMENTS[view]})
            args = view_arguments(view, query)
            loop = asyncio.get_running_loop()
            body = await loop.run_in_executor(self.executor, _compute, view, state, args)
        except ParameterError as e:
            self.set_status(400)
            return self.finish(dumps({"error": str(e), "parameter": e.name}))
        except PreciseImpactError as e:
            self.set_status(422)
            return self.finish(dumps({"error": " ".join(str(e).splitlines())}))
        self.finish(body)


def _compute(view: str, state: State, args: dict[str, Any]) -> str:
    """The view's dict as strict JSON text (on a worker thread)."""
    return dumps(run_view(view, state, **args))


def api_patterns(executor: concurrent.futures.Executor) -> list[tuple[str, type, dict]]:
    """The tornado routes of the API, for a server's ``extra_patterns``."""
    kw = {"executor": executor}
    return [(r"/api/?", ApiHandler, kw), (r"/api/([a-z-]+)", ApiHandler, kw)]
