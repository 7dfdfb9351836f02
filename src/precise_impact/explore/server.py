"""``precise-impact explore``'s server: Panel's Bokeh server with the page at ``/`` and the JSON
API at ``/api``, every asset served locally (no CDN), one thread pool for every session."""

from __future__ import annotations

import concurrent.futures
import contextlib
import os
import signal
from collections.abc import Callable
from typing import Any

import panel as pn

from precise_impact.explore.app import make_session
from precise_impact.explore.http import api_patterns

__all__ = ["make_server", "serve"]


def make_server(
    address: str = "127.0.0.1", port: int = 5006, threads: int | None = None,
    dask: str | None = None,
) -> Any:  # fmt: skip
    """The explorer's server, not started: the page at ``/`` and the API at ``/api`` (the
    page's domains of attraction on the Dask scheduler ``dask`` when given)."""
    pn.config.raw_css = []
    # threads enough that no view queues behind another's run (a page runs up to 8 at once:
    # orbit, LLE, two circuit models, impact map, basins, diagram, proof); a superseded run ends
    # in its thread, its result dropped
    executor = concurrent.futures.ThreadPoolExecutor(threads or max(8, 4 * (os.cpu_count() or 2)))
    origins = [f"{address}:{port}", f"localhost:{port}", f"127.0.0.1:{port}"]

    def page() -> Any:  # a plain function: Panel calls it once per browser session
        return make_session(executor, dask)

    before = signal.getsignal(signal.SIGINT)
    server = pn.serve(
        {"/": page},
        address=address, port=port, show=False, start=False, threaded=False,
        websocket_origin=origins, title="precise_impact explorer",
        extra_patterns=api_patterns(executor), location=True,
    )  # fmt: skip
    # Panel puts in its own Ctrl-C handler, which stops the loop quietly (exit 0): Ctrl-C stays
    # the CLI's (exit 130, one line), as SIGTERM is
    with contextlib.suppress(ValueError):  # not the main thread: no handler was put in either
        signal.signal(signal.SIGINT, before)
    return server


def serve(
    address: str = "127.0.0.1",
    port: int = 5006,
    open_browser: bool = False,
    say: Callable[[str], None] = print,
    dask: str | None = None,
) -> None:
    """Serve until interrupted (Ctrl-C / SIGTERM end it with the CLI's exit 130)."""
    server = make_server(address, port, dask=dask)
    server.start()
    url = f"http://{address}:{server.port}/"
    say(f"precise-impact explore: {url} (JSON API: {url}api; Ctrl-C ends it)")
    if open_browser:
        server.io_loop.add_callback(server.show, "/")
    server.io_loop.start()
