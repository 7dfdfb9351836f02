"""What users bring from the bench: their netlists and SPICE waveform files (:mod:`.netlist`),
oscilloscope captures (:mod:`.capture`, read by :mod:`.scope_files`, synthesised through a
measurement model by :mod:`.synth`, scored at the level of the attractor by :mod:`.attractor`,
the oscillator they realise identified by :mod:`.identify`, what it does predicted by
:mod:`.predict`, the part that differs by :mod:`.diagnose`), and tolerance budgets
(:mod:`.budget`).  Guides: ``docs/guide/`` netlist, captures, identify and tolerance."""

__all__ = [
    "attractor",
    "budget",
    "capture",
    "diagnose",
    "identify",
    "netlist",
    "predict",
    "scope_files",
    "scope_writers",
    "synth",
]
