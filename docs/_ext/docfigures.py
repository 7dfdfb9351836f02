"""``.. runfigure::``: a figure made at build time by the code shown above it.

The directive prints its content as a Python code block, runs it in a fresh namespace
(``pi``, ``np``, ``math`` imported, as in the doctest setup) with a temporary working
directory, and puts every ``.png`` file the code wrote beneath the code, in the order
written.  So a page shows the exact code a reader runs (the package's own ``.plot(path)``
methods, its ``--out`` commands, or a few lines of matplotlib) and the image it makes.

Options: ``:caption:`` (below the image), ``:alt:`` (default: the caption), ``:width:``
(default ``100%``).  A failing run or one that writes no ``.png`` is a build error.  The time
each figure took is summed and logged at the end of the build (``docfigures: N figures in
S s``).  Images go to ``<doctreedir>/../_docfigures/`` (the html output's folder with the
default ``-d``) and are copied to ``_images/`` by the builder like any other image.
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
import time
import traceback
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import directives
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

logger = logging.getLogger(__name__)

_TIMES: list[tuple[str, float]] = []


@contextlib.contextmanager
def _cwd(path: str):
    old = os.getcwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(old)


def _run(code: str, where: str) -> None:
    import math

    import matplotlib.pyplot as plt
    import numpy as np

    import precise_impact

    namespace = {"__name__": "__docfigure__", "pi": precise_impact, "np": np, "math": math}
    try:  # what the code prints is not part of the page (the build log stays quiet)
        with _cwd(where), contextlib.redirect_stdout(io.StringIO()):
            exec(compile(code, "<runfigure>", "exec"), namespace)
    finally:
        plt.close("all")


class RunFigure(SphinxDirective):
    has_content = True
    option_spec = {
        "caption": directives.unchanged,
        "alt": directives.unchanged,
        "width": directives.unchanged,
    }

    def run(self) -> list[nodes.Node]:
        code = "\n".join(self.content)
        docname = self.env.docname
        serial = self.env.new_serialno("runfigure")
        out_dir = Path(self.env.doctreedir).parent / "_docfigures" / Path(docname).parent
        out_dir.mkdir(parents=True, exist_ok=True)
        stem = f"{Path(docname).name}-{serial}"

        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            try:
                _run(code, tmp)
            except Exception:
                tb = traceback.format_exc(limit=-3)
                raise self.error(f"runfigure in {docname}: the code raised\n{tb}") from None
            written = sorted(Path(tmp).rglob("*.png"), key=lambda p: (p.stat().st_mtime_ns, p.name))
            if not written:
                raise self.error(f"runfigure in {docname}: the code wrote no .png file")
            images = []
            for png in written:
                dest = out_dir / f"{stem}-{png.name}"
                dest.write_bytes(png.read_bytes())
                images.append(dest)
        _TIMES.append((docname, time.perf_counter() - t0))

        block = nodes.literal_block(code, code)
        block["language"] = "python"
        self.set_source_info(block)

        caption = self.options.get("caption", "")
        figure = nodes.figure()
        doc_dir = Path(self.env.srcdir) / Path(docname).parent
        for img in images:
            uri = os.path.relpath(img, doc_dir)
            figure += nodes.image(
                uri=uri,
                alt=self.options.get("alt", caption or img.name),
                width=self.options.get("width", "100%"),
            )
        if caption:
            parsed, _ = self.state.inline_text(caption, self.lineno)
            figure += nodes.caption(caption, "", *parsed)
        self.set_source_info(figure)
        return [block, figure]


def _report(app, exc) -> None:
    if _TIMES:
        total = sum(t for _, t in _TIMES)
        each = ", ".join(f"{doc} {t:.1f} s" for doc, t in _TIMES)
        logger.info(f"docfigures: {len(_TIMES)} figures in {total:.1f} s ({each})")


def setup(app):
    os.environ.setdefault("MPLBACKEND", "Agg")  # pyplot in the examples, without a display
    app.add_directive("runfigure", RunFigure)
    app.connect("build-finished", _report)
    return {"version": "1", "parallel_read_safe": False, "parallel_write_safe": True}
