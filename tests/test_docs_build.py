"""The documentation build's own machinery, on a one-page project with the real docs/conf.py.

* math renders offline: the MathJax the [docs] extra ships is copied into ``_static/`` and no
  page loads a script (or a stylesheet) from another host;
* ``.. runfigure::`` shows the code and the PNG it wrote; a failing run fails the build;
* the tables of the circuit-builders page list what the code accepts.

The whole documentation is built (``-W``, html and doctest) by scripts/test-installed.sh,
which also checks every built page for remote scripts (:func:`remote_sources`).
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
pytest.importorskip("sphinx")
pytest.importorskip("numpydoc")
pytestmark = pytest.mark.skipif(
    not (DOCS / "conf.py").is_file(), reason="needs the checkout's docs/"
)

PAGE = r"""
Test page
=========

.. math::

   \ddot x + 2\zeta \dot x + x = a\cos(\eta t)

.. runfigure::
   :caption: A line.

   import matplotlib.pyplot as plt

   fig, ax = plt.subplots(figsize=(2, 2))
   ax.plot([0, 1], [0, 1])
   fig.savefig("line.png", dpi=50)

.. components-table::

.. effects-table::
"""


def remote_sources(html: str) -> list[str]:
    """``src``/``href`` of the scripts and stylesheets of a page that point to another host."""
    tags = re.findall(r"<(?:script|link)\b[^>]*>", html)
    urls = [m for t in tags for m in re.findall(r'(?:src|href)="([^"]*)"', t)]
    return [u for u in urls if re.match(r"(?:[a-z]+:)?//", u, re.I)]


def _build(tmp_path: Path, page: str) -> tuple[int, Path, str]:
    from sphinx.cmd.build import build_main

    src = tmp_path / "src"
    src.mkdir()
    shutil.copy(DOCS / "conf.py", src / "conf.py")
    shutil.copytree(DOCS / "_ext", src / "_ext")
    shutil.copytree(DOCS / "_static", src / "_static")
    (src / "index.rst").write_text(page, encoding="utf-8")
    out = tmp_path / "html"
    warnings = tmp_path / "warnings.txt"
    status = build_main(["-q", "-W", "-w", str(warnings), "-b", "html", str(src), str(out)])
    return status, out, warnings.read_text(encoding="utf-8")


def test_remote_sources_finds_cdn_scripts():
    page = (
        '<script src="_static/doctools.js"></script>'
        '<script async="async" src="https://cdn.jsdelivr.net/npm/mathjax@3/es5/tex-mml-chtml.js">'
        '<link rel="stylesheet" href="//fonts.example.org/a.css" />'
    )
    assert remote_sources(page) == [
        "https://cdn.jsdelivr.net/npm/mathjax@3/es5/tex-mml-chtml.js",
        "//fonts.example.org/a.css",
    ]


def test_one_page_build_offline_math_figure_tables(tmp_path):
    status, out, warnings = _build(tmp_path, PAGE)
    assert status == 0, warnings
    html = (out / "index.html").read_text(encoding="utf-8")
    assert remote_sources(html) == []
    # MathJax is served from the build itself
    (script,) = re.findall(r'<script[^>]*src="(_static/mathjax/[^"]+)"', html)
    assert (out / script).is_file()
    assert (out / "_static/mathjax/output/chtml/fonts/woff-v2/MathJax_Main-Regular.woff").is_file()
    assert (out / "_static/custom.css").is_file() and "_static/custom.css" in html
    # the figure: the code above the image the code wrote
    code = html.index('<div class="highlight-python')
    assert "savefig" in html[code:]
    (img,) = re.findall(r'<img[^>]*src="(_images/[^"]*line\.png)"', html[code:])
    assert (out / img).stat().st_size > 0
    # the tables list every [components] key and every effect, from the code
    from precise_impact.models.circuit.effects.catalogue import EFFECTS
    from precise_impact.scenes.scene import COMPONENT_KEYS

    for name in [*COMPONENT_KEYS, *EFFECTS]:
        assert f'<span class="pre">{name}</span>' in html, name
    # R6 sets the damping alone: x4 gives zeta x1/4
    row = re.search(r"<span class=\"pre\">R6</span>.*?</tr>", html, re.S).group(0)
    assert "zeta</span></code> \u00d71/4" in row and ">eta</span></code>" not in row


def test_failing_figure_code_fails_the_build(tmp_path):
    page = "Page\n====\n\n.. runfigure::\n\n   raise RuntimeError('no figure today')\n"
    status, _, warnings = _build(tmp_path, page)
    assert status != 0
    assert "no figure today" in warnings


def test_code_is_not_clipped():
    # alabaster's default 940 px column showed ~55 characters of a code line, the rest behind
    # a scroll bar: the page is wider and code lines wrap
    text = (DOCS / "conf.py").read_text(encoding="utf-8")
    assert '"page_width": "1240px"' in text and '"body_max_width": "none"' in text
    css = (DOCS / "_static" / "custom.css").read_text(encoding="utf-8")
    assert re.search(r"div\.highlight pre \{[^}]*white-space: pre-wrap", css)
