"""What the trajectories mean: Lyapunov exponents, periods, orbits, synchronisation, scans."""

from precise_impact.analysis.bifurcation import BifurcationResult, bifurcation
from precise_impact.analysis.lyapunov import (
    LYAPUNOV_ENGINES,
    LYAPUNOV_METHODS,
    Attractor,
    LyapunovResult,
    StartEstimate,
    lyapunov,
)
from precise_impact.analysis.periodicity import detect_period
from precise_impact.analysis.sweep import SweepResult, SweepSpec, load_sweep, run_sweep
from precise_impact.analysis.sync import SyncResult, sync_scan

__all__ = [
    "LYAPUNOV_METHODS",
    "LYAPUNOV_ENGINES",
    "LyapunovResult",
    "Attractor",
    "StartEstimate",
    "lyapunov",
    "detect_period",
    "SyncResult",
    "sync_scan",
    "BifurcationResult",
    "bifurcation",
    "SweepSpec",
    "SweepResult",
    "run_sweep",
    "load_sweep",
]
