"""The explorer: live, linked views of the oscillator, its circuit and its proofs in the
browser (``precise-impact explore``), and the JSON API they are built on.

:mod:`.state` is what a view shows (one URL query string), :mod:`.api` the computations, one
function per view.  The guide: ``docs/guide/explore.rst``.
"""
