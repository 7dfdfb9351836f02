"""``precise-impact explore``: the explorer in the browser and its JSON API
(``pip install 'precise_impact[explore]'``)."""

from __future__ import annotations

import argparse

from precise_impact.core.params import check_count
from precise_impact.errors import OptionalDependencyError, ParameterError


def register(sub) -> argparse.ArgumentParser:
    """Add ``explore`` to ``sub``."""
    e = sub.add_parser(
        "explore",
        help="live, linked views in the browser (orbit, bifurcation diagram, proofs) and a "
        "JSON API, served on the loopback",
    )
    e.add_argument(
        "--address",
        default="127.0.0.1",
        help="address to serve on (the loopback, 127.0.0.1, by default)",
    )
    e.add_argument("--port", default="5006", help="port, 0 for any free one (default 5006)")
    e.add_argument("--show", action="store_true", help="open the page in the default browser")
    e.add_argument(
        "--dask", metavar="tcp://HOST:PORT", default=None,
        help="run the domains of attraction on this Dask scheduler (pip install "
        "'precise_impact[dask]')",
    )  # fmt: skip
    e.set_defaults(run=run)
    return e


def run(ns: argparse.Namespace) -> int:
    """Run ``explore`` until interrupted; returns the exit status."""
    port = check_count(ns.port, "port", 65535)
    if not ns.address or any(c.isspace() for c in ns.address):
        raise ParameterError("address", ns.address, "a host name or IP address")
    try:
        from precise_impact.explore.server import serve  # noqa: PLC0415 -- optional: panel
    except ImportError as e:
        raise OptionalDependencyError(
            "panel", "pip install 'precise_impact[explore]'", "explore"
        ) from e
    if ns.dask is not None and not ns.dask.startswith("tcp://"):
        raise ParameterError("dask", ns.dask, "a scheduler address tcp://HOST:PORT")
    serve(ns.address, port, open_browser=ns.show, dask=ns.dask)
    return 0
