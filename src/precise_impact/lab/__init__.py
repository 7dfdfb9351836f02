"""What users bring from the bench: their netlists and SPICE waveform files (:mod:`.netlist`),
oscilloscope captures (:mod:`.capture`, read by :mod:`.scope_files`, synthesised through a
measurement model by :mod:`.synth`, scored at the level of the attractor by :mod:`.attractor`,
the oscillator they realise identified by :mod:`.identify`, what it does predicted by
:mod:`.predict`), and the tolerance budget of a circuit design (:mod:`.budget`).  Guides:
``docs/guide/netlist.rst``, ``docs/guide/captures.rst``, ``docs/guide/identify.rst``,
``docs/guide/tolerance.rst``."""

__all__ = [
    "attractor",
    "budget",
    "capture",
    "identify",
    "netlist",
    "predict",
    "scope_files",
    "scope_writers",
    "synth",
]
