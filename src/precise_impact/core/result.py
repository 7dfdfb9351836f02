"""One base for result types: ``to_dict()`` (JSON-ready) and ``save(path)`` (atomic)."""

from __future__ import annotations

import dataclasses
import functools
import os
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.core.params import Params, decimal_str
from precise_impact.core.precision import Precision, exact_value, float_up
from precise_impact.errors import OptionalDependencyError, ParameterError
from precise_impact.io.atomic import atomic_write
from precise_impact.io.jsonout import finite_or_marker, write_json

__all__ = [
    "ResultMixin",
    "to_jsonable",
    "short_repr",
    "unit_column",
    "unit_of",
    "float_column",
    "columns",
    "ball_columns",
    "record_columns",
    "flat",
]


def to_jsonable(obj: Any) -> Any:
    """``obj`` in plain JSON types, strict JSON: a NaN becomes ``None`` and an infinity the
    string ``'inf'`` or ``'-inf'`` (:func:`precise_impact.io.jsonout.finite_or_marker`)."""
    out = _leaf_jsonable(obj)
    if out is not _NOT_A_LEAF:
        return out
    return _container_jsonable(obj)


_NOT_A_LEAF = object()


def _leaf_jsonable(obj: Any) -> Any:
    """``obj`` as one JSON value if it is a scalar-like leaf, else the ``_NOT_A_LEAF`` marker."""
    if obj is None or isinstance(obj, (bool, str, int)):
        return obj
    if isinstance(obj, float):
        return finite_or_marker(obj)
    if isinstance(obj, Fraction):
        return decimal_str(obj)
    if isinstance(obj, Params):
        return obj.decimal()
    if isinstance(obj, Precision):
        return obj.name
    if isinstance(obj, ResultMixin):
        return obj.to_dict()
    if isinstance(obj, Path):
        return str(obj)
    return _NOT_A_LEAF


def _container_jsonable(obj: Any) -> Any:
    """Numpy values, containers and dataclasses converted element by element; else ``str(obj)``."""
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "fiub":
            return [to_jsonable(v) for v in obj.tolist()]
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if dataclasses.is_dataclass(obj):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    return str(obj)  # heyoka real / real128: their str() round-trips


def unit_column(name: str, unit: str) -> str:
    """A table column's name with its unit: ``'x [1]'``, ``'time [s]'``."""
    return f"{name} [{unit}]"


def float_column(values: Any, precision: Precision | None = None) -> np.ndarray:
    """``values`` (any precision's numbers, ``None`` for not recorded) as a float64 array."""
    if precision is not None:
        return np.array(
            [np.nan if v is None else precision.to_float(v) for v in values], dtype=float
        )
    return np.array([np.nan if v is None else float(v) for v in values], dtype=float)


def columns(*cols: tuple[str, str | None, Any], precision: Precision | None = None) -> dict:
    """``{'name [unit]': float64 array}`` for each ``(name, unit, values)`` (numbers of
    ``precision``'s type converted, ``None`` / NaN for not recorded); a ``None`` unit keeps
    the values as they are under the bare name (counts, labels, flags)."""
    out: dict[str, Any] = {}
    for name, unit, values in cols:
        if unit is None:
            out[name] = np.asarray(values)
        else:
            out[unit_column(name, unit)] = float_column(values, precision)
    return out


#: Units of the named quantities in tables (``to_dataframe``): dimensionless state, time
#: and distances ``[1]``, rates per unit dimensionless time ``[1/tau]``, wall times ``[s]``.
_RATE_WORDS = ("lle", "rate", "lambda")
_STATE_WORDS = (
    "error",
    "eta",
    "x",
    "v",
    "y",
    "w",
    "t",
    "dt",
    "dv",
    "value",
    "agreement",
    "wasserstein",
    "floor",
    "horizon",
    "demonstrated",
    "stderr",
    "shift",
    "k",
    "final",
    "minimum",
    "y0",
)


def unit_of(key: str) -> tuple[str, str | None]:
    """``(name, unit)`` of a table column from a result's key: ``elapsed_s`` -> ``('elapsed',
    's')``, an exponent or rate ``'1/tau'``, a dimensionless state, time, error or distance
    ``'1'``; counts, labels and flags ``None`` (no unit)."""
    if key.endswith("_s"):
        return key[:-2], "s"
    words = key.replace(".", "_").replace(" ", "_").split("_")
    if any(w in _RATE_WORDS for w in words):
        return key, "1/tau"
    if any(w in _STATE_WORDS for w in words) or key.startswith("horizon"):
        return key, "1"
    return key, None


def _number(v: Any) -> Any:
    """A decimal string (``'0.712'``, ``'89/58'``) as its float; anything else unchanged."""
    if isinstance(v, str):
        try:
            return float(Fraction(v))
        except (ValueError, ZeroDivisionError):
            return v
    return v


def record_columns(rows: Any, first: dict | None = None) -> dict:
    """Columns of a list of flat dicts (keys in first-seen order), named with their units
    (:func:`unit_of`): numbers as float64 (``None`` NaN; decimal strings read), other values
    as they are under the bare key.  ``first``:
    columns put before them (already named)."""
    keys: dict[str, None] = {}
    for r in rows:
        keys.update(dict.fromkeys(r))
    out: dict[str, Any] = dict(first or {})
    for key in keys:
        vals = [_number(r.get(key)) for r in rows]
        name, unit = unit_of(key)
        numeric = all(
            v is None or (isinstance(v, (int, float, np.number)) and not isinstance(v, bool))
            for v in vals
        ) and any(v is not None for v in vals)
        if unit is not None and numeric:
            out[unit_column(name, unit)] = float_column(vals)
        else:  # counts, labels, flags, text: the key itself
            out[key] = vals
    return out


def flat(d: dict, prefix: str = "") -> dict:
    """A nested dict's scalar leaves as one flat dict (``a.b`` keys); lists left out."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(flat(v, f"{prefix}{k}."))
        elif not isinstance(v, (list, tuple, np.ndarray)):
            out[f"{prefix}{k}"] = v
    return out


def ball_columns(names: tuple[str, ...], rows: Any) -> dict:
    """Columns of rows of balls (python-flint ``arb``): ``'name [1]'`` the midpoint as float64
    and ``'rad_name [1]'`` its radius rounded up; a name ``'period'`` is an integer column."""
    out: dict[str, Any] = {}
    for i, name in enumerate(names):
        vals = [r[i] for r in rows]
        if name == "period":
            out[name] = np.asarray(vals, dtype=int)
            continue
        out[unit_column(name, "1")] = np.array([float(b.mid()) for b in vals], dtype=float)
        # the radius rounded up (a bound on the midpoint's error stays a bound; below 1e-308
        # the smallest subnormal, never 0.0)
        rad = [float_up(exact_value(b.rad())) for b in vals]
        out[unit_column("rad_" + name, "1")] = np.array(rad, dtype=float)
    return out


#: Longest ``repr`` of a result (characters): a few lines, whatever the result holds.
REPR_LIMIT = 400
#: Properties shown in a result's ``repr`` beside its fields, where the type has them.
_REPR_PROPERTIES = ("periods", "n_impacts")


def _brief(v: Any) -> str:
    """A value in a few characters: scalars themselves, containers by their sizes."""
    if v is None or isinstance(v, (bool, int)):
        return repr(v)
    if isinstance(v, float):
        return format(v, ".6g")
    if isinstance(v, str):
        return repr(v if len(v) <= 40 else v[:37] + "...")
    if isinstance(v, Fraction):
        text = decimal_str(v)
        return text if len(text) <= 24 else format(float(v), ".12g")
    if isinstance(v, Precision):
        return v.name
    if isinstance(v, Params):
        return "Params(" + ", ".join(f"{k}={x}" for k, x in v.decimal().items()) + ")"
    if isinstance(v, np.ndarray):
        return f"<{'x'.join(map(str, v.shape))} {v.dtype}>"
    if isinstance(v, np.generic):
        return _brief_generic(v)
    if isinstance(v, (list, tuple)):
        return _brief_sequence(v)
    if isinstance(v, dict):
        return f"<{len(v)} keys>"
    if isinstance(v, ResultMixin):
        return f"<{type(v).__name__}>"
    return f"<{type(v).__name__}>"


def _brief_generic(v: np.generic) -> str:
    """A numpy scalar (or heyoka's real / real128) in a few characters."""
    x = v.item()
    if type(x) is not type(v):  # a numpy scalar: its Python value
        return _brief(x)
    try:  # heyoka's real / real128: 6 digits (str() gives all of them)
        return format(float(v), ".6g")
    except (TypeError, ValueError):
        return f"<{type(v).__name__}>"


def _brief_sequence(v: list | tuple) -> str:
    """A short list or tuple of scalars itself, any other by its length."""
    if len(v) <= 3 and all(isinstance(x, (int, float, Fraction, str)) for x in v):
        return "(" + ", ".join(_brief(x) for x in v) + ")"
    return f"<{len(v)} items>"


def short_repr(self: Any) -> str:
    """``Type(field=value, ...)``, one line: the scalar fields first, then ``periods`` and
    ``n_impacts`` where the type has them, then the arrays by their sizes (fields of one
    shape grouped: ``t,x,v=<201 object>``) and the containers by theirs; ``None`` fields left
    out; cut at :data:`REPR_LIMIT` characters."""
    scalars: list[str] = []
    containers: list[str] = []
    arrays: dict[tuple[str, str], list[str]] = {}
    for f in dataclasses.fields(self):
        v = getattr(self, f.name)
        if not f.repr or v is None:
            continue
        if isinstance(v, np.ndarray):
            arrays.setdefault(("x".join(map(str, v.shape)), str(v.dtype)), []).append(f.name)
        elif isinstance(v, (list, tuple, dict)) and _brief(v).startswith("<"):
            containers.append(f"{f.name}={_brief(v)}")
        else:
            scalars.append(f"{f.name}={_brief(v)}")
    for name in _REPR_PROPERTIES:
        if isinstance(getattr(type(self), name, None), property):
            try:
                scalars.append(f"{name}={_brief(getattr(self, name))}")
            except Exception:  # a property that cannot be computed on this result
                pass
    grouped = [f"{','.join(n)}=<{shape} {dt}>" for (shape, dt), n in arrays.items()]
    text = f"{type(self).__name__}(" + ", ".join(scalars + grouped + containers) + ")"
    return text if len(text) <= REPR_LIMIT else text[: REPR_LIMIT - 4] + "...)"


class ResultMixin:
    """``to_dict()``, ``save(path)`` and (for one release) ``result["field"]`` for dataclass
    results.

    See Also
    --------
    precise_impact.core.trajectory.Trajectory : a result using it.
    precise_impact.analysis.lyapunov.result.LyapunovResult : another.
    """

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """A result type's own ``to_dict`` is made strict JSON once, here: its output passes
        through :func:`to_jsonable` (finite numbers, strings and containers unchanged; NaN
        ``None``, infinities ``'inf'`` / ``'-inf'``, numpy values plain).  Its ``repr`` is
        the short one of :func:`short_repr` unless the class writes its own (set before
        ``@dataclass`` runs, which then keeps it)."""
        super().__init_subclass__(**kwargs)
        if "__repr__" not in cls.__dict__:
            cls.__repr__ = short_repr  # type: ignore[method-assign]
        own = cls.__dict__.get("to_dict")
        if own is None or getattr(own, "_strict_json", False):
            return

        @functools.wraps(own)
        def to_dict(self: Any, *args: Any, **kw: Any) -> Any:
            return to_jsonable(own(self, *args, **kw))

        to_dict._strict_json = True  # type: ignore[attr-defined]
        cls.to_dict = to_dict  # type: ignore[method-assign]

    def to_dict(self) -> dict[str, Any]:
        """The result as plain JSON types; ``json.dumps(result.to_dict(), allow_nan=False)``
        always works (NaN is ``null``, an infinity ``"inf"`` / ``"-inf"``)."""
        return {f.name: to_jsonable(getattr(self, f.name)) for f in dataclasses.fields(self)}  # type: ignore[arg-type]

    def _tables(self) -> dict[str, Callable[[], dict[str, Any]]]:
        """The tables :meth:`to_dataframe` offers: name -> a function giving ``{column: values}``
        (columns named with their units, :func:`unit_column`); the first is the default.  A
        result type with samples or rows overrides it; the others have none."""
        return {}

    def to_dataframe(self, what: str | None = None) -> Any:
        """The result's samples or rows as a :class:`pandas.DataFrame` (pandas is optional:
        ``pip install 'precise_impact[pandas]'``).

        Parameters
        ----------
        what : str or None, default ``None``
            Which table, for a result with several (a trajectory: ``'samples'``,
            ``'impacts'``, ``'dense'``); ``None`` is the first (see :meth:`tables`).

        Returns
        -------
        pandas.DataFrame
            Numbers as float64 (``bool``, ``int`` and text columns kept), columns named with
            their unit in brackets: ``[1]`` dimensionless (time ``t`` is ``tau = Omega t``),
            ``[1/tau]`` a rate per unit dimensionless time, ``[s]`` wall time.

        Raises
        ------
        OptionalDependencyError
            pandas is not installed.
        ParameterError
            ``what`` is not one of the result's tables, or the result has none.
        """
        tables = self._tables()
        if not tables:
            raise ParameterError(
                "what", what, f"{type(self).__name__} has no samples or rows (use to_dict())"
            )
        name = next(iter(tables)) if what is None else what
        if name not in tables:
            raise ParameterError("what", what, "one of " + ", ".join(map(repr, tables)))
        try:
            import pandas as pd  # noqa: PLC0415 -- optional: loaded on first use
        except ImportError:
            raise OptionalDependencyError(
                "pandas", "pip install 'precise_impact[pandas]'", "to_dataframe()"
            ) from None
        return pd.DataFrame(tables[name]())

    def tables(self) -> tuple[str, ...]:
        """The names :meth:`to_dataframe` takes, the default first (empty: no rows)."""
        return tuple(self._tables())

    def save(self, path: str | os.PathLike) -> Path:
        """Write the result atomically: ``.json`` (:meth:`to_dict`) or ``.npz`` (its arrays and
        scalars).

        Returns
        -------
        pathlib.Path
            The file written.

        Raises
        ------
        ParameterError
            ``path`` ends in neither ``.json`` nor ``.npz``.
        """
        path = Path(path)
        if path.suffix == ".json":
            write_json(path, self.to_dict())
        elif path.suffix == ".npz":
            arrays: dict[str, Any] = {}
            for f in dataclasses.fields(self):  # type: ignore[arg-type]
                v = getattr(self, f.name)
                if isinstance(v, np.ndarray) and v.dtype != object:
                    arrays[f.name] = v
                elif isinstance(v, (int, float, bool, np.generic)):
                    arrays[f.name] = np.asarray(v)
            atomic_write(path, lambda fh: np.savez_compressed(fh, **arrays), binary=True)
        else:
            raise ParameterError("path", str(path), "a file ending in .json or .npz")
        return path

    def __contains__(self, key: object) -> bool:
        return key in {f.name for f in dataclasses.fields(self)}  # type: ignore[arg-type]

    def __getitem__(self, key: str) -> Any:
        names = {f.name for f in dataclasses.fields(self)}  # type: ignore[arg-type]
        if key not in names:
            raise KeyError(key)
        return getattr(self, key)
