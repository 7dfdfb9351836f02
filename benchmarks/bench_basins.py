"""Domain-of-attraction benchmark (issue 25), results in benchmarks/results/basins.{json,md,png}.

Run:  python benchmarks/bench_basins.py [--n 1000] [--workers 2] [--dask-workers 2]

Two cases on the impact surface, each map end to end three ways:

* ``chatter``: Budd and Dux's chatter case (eta = 4.85, R = 0.5, x_w = -0.3, zeta = 0, a = 1),
  phase in [0, 1) x v in (0, 0.6], ``--n x --n`` points (default 1000 x 1000), transient 60;
* ``paper``: the paper's eta = 0.74 (two stable periodic orbits: Newton refinements and the
  boundary re-runs at scale), phase x v in (0, 3], ``--n-paper`` squared points (default
  200 x 200), transient 100.

The three ways:

* one process (the reference of the scaling efficiency);
* ``--workers`` local worker processes (``run_scan``'s process pool);
* a Dask cluster started here with the real commands on the loopback: ``dask scheduler``
  and ``dask worker`` (the current spelling of ``dask-scheduler`` / ``dask-worker``),
  ``--dask-workers`` worker processes of one thread each; they are shut down on exit, also
  on Ctrl-C.

Time per point, the scaling efficiency ``T_1 / (N T_N)`` and the peak resident memory of the
driver and of every worker process are written.  The labels of the three runs must agree
point for point (checked).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import socket
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from dask.distributed import Client

from precise_impact import Params
from precise_impact.analysis.impact_surface.basins import basins
from precise_impact.io.atomic import atomic_write

OUT = Path(__file__).resolve().parent / "results"
DASK = Path(sys.executable).with_name("dask")
PRELOAD = Path(__file__).resolve().with_name("dask_preload.py")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class LoopbackCluster:
    """``dask scheduler`` + ``dask worker`` processes on 127.0.0.1, ended on exit."""

    def __init__(self, n_workers: int) -> None:
        self.port = _free_port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        self.procs: list[subprocess.Popen] = []
        log = open(os.devnull, "w")
        self.procs.append(
            subprocess.Popen(
                [str(DASK), "scheduler", "--host", "127.0.0.1", "--port", str(self.port),
                 "--no-dashboard"],
                stdout=log, stderr=log, start_new_session=True,
            )
        )  # fmt: skip
        self.procs.append(
            subprocess.Popen(
                [str(DASK), "worker", self.address, "--nworkers", str(n_workers), "--nthreads",
                 "1", "--no-dashboard", "--memory-limit", "0", "--preload", str(PRELOAD)],
                stdout=log, stderr=log, start_new_session=True,
            )
        )  # fmt: skip
        deadline = time.time() + 60
        while True:
            try:
                with Client(self.address, timeout=5) as c:
                    if len(c.scheduler_info()["workers"]) >= n_workers:
                        break
            except OSError:
                pass
            if time.time() > deadline:
                self.close()
                raise RuntimeError("the loopback Dask cluster did not come up in 60 s")
            time.sleep(0.5)

    def peak_rss_mib(self) -> list[float]:
        with Client(self.address, timeout=10) as c:
            got = c.run(lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
        return sorted(got.values())

    def close(self) -> None:
        for p in reversed(self.procs):  # workers first, then the scheduler: each by its group
            if p.poll() is None:
                try:
                    os.killpg(p.pid, signal.SIGTERM)
                except OSError:
                    pass
        for p in self.procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()


def _task_stream_breakdown(records: list[dict], wall: float, n_workers: int) -> dict:
    """Where the Dask run's time went, from the scheduler's task stream: the tasks' compute
    time on the workers (per worker, first task, mean), their deserialize and transfer time,
    and the workers' idle time ``n_workers x wall - busy``."""
    per: dict[str, list[float]] = {}
    other = {"deserialize": 0.0, "transfer": 0.0}
    for r in records:
        for ss in r.get("startstops", ()):
            d = ss["stop"] - ss["start"]
            if ss["action"] == "compute":
                per.setdefault(r["worker"], []).append((ss["start"], d))
            elif ss["action"] in other:
                other[ss["action"]] += d
    comp = {w: [d for _, d in sorted(v)] for w, v in per.items()}
    busy = sum(sum(v) for v in comp.values()) + sum(other.values())
    return {
        "tasks": sum(len(v) for v in comp.values()),
        "compute_s_per_worker": sorted(sum(v) for v in comp.values()),
        "first_task_s": sorted(v[0] for v in comp.values()),
        "mean_task_s": sum(sum(v) for v in comp.values())
        / max(1, sum(len(v) for v in comp.values())),
        "deserialize_s": other["deserialize"],
        "transfer_s": other["transfer"],
        "idle_s": n_workers * wall - busy,
    }


def _kernel_loads(dask_worker=None) -> tuple:
    """On a worker: the strobe kernel's numba cache hits and misses (compilations), and the
    preload's warm-up seconds."""
    from precise_impact.solvers.fast.single import strobe  # noqa: PLC0415 -- runs on a worker

    st = strobe.stats
    warm = getattr(dask_worker, "precise_impact_warmup_s", None)
    return sum(st.cache_hits.values()), sum(st.cache_misses.values()), warm


def _run_dask(params, grid, kw, cluster, n_workers) -> tuple[dict, object]:
    """One map on the loopback cluster, with the breakdown from the scheduler's task stream."""
    with Client(cluster.address, timeout=10) as c:
        c.get_task_stream(start=time.time())  # installs the scheduler's task-stream plugin
        t0 = time.time()
        t = time.perf_counter()
        res = basins(params, grid, dask=cluster.address, **kw)
        wall = time.perf_counter() - t
        stream = c.get_task_stream(start=t0)
        kernels = c.run(_kernel_loads)
    run = {"wall_s": wall, "workers": n_workers, "address": cluster.address}
    run["breakdown"] = _task_stream_breakdown(stream, wall, n_workers)
    run["breakdown"]["strobe_cache_hits_misses_per_worker"] = sorted(kernels.values())
    return run, res


def run_case(name, params, grid, transient, args) -> tuple[dict, object]:
    """One map: serial, then ``--repeat`` rounds of processes and Dask, interleaved."""
    n_points = grid[0][2] * grid[1][2]
    kw = dict(transient=transient, tile_size=args.tile_size, progress=True)
    runs: dict = {}
    results = {}
    if not args.skip_serial:
        t = time.perf_counter()
        results["serial"] = basins(params, grid, workers=1, **kw)
        runs["serial"] = {"wall_s": time.perf_counter() - t, "workers": 1}
    cluster = LoopbackCluster(args.dask_workers)  # started once: round 1 pays the workers' warm-up
    try:
        for k in range(1, args.repeat + 1):
            before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
            t = time.perf_counter()
            results[f"processes #{k}"] = basins(params, grid, workers=args.workers, **kw)
            runs[f"processes #{k}"] = {
                "wall_s": time.perf_counter() - t, "workers": args.workers,
                "worker_peak_rss_MiB": max(
                    before, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
                ),
            }  # fmt: skip
            runs[f"dask #{k}"], results[f"dask #{k}"] = _run_dask(
                params, grid, kw, cluster, args.dask_workers
            )
            runs[f"dask #{k}"]["worker_peak_rss_MiB"] = cluster.peak_rss_mib()
            runs[f"dask #{k}"]["load_average_1"] = os.getloadavg()[0]
    finally:
        cluster.close()
    ref = runs.get("serial", {}).get("wall_s")
    for key, r in runs.items():
        res = results[key]
        r["time_per_point_us"] = 1e6 * r["wall_s"] / n_points
        r["scan_time_per_point_us"] = 1e6 * res.stats["time_per_point_s"]
        r["efficiency"] = ref / (r["workers"] * r["wall_s"]) if ref else None
    ratios = [
        runs[f"processes #{k}"]["wall_s"] / runs[f"dask #{k}"]["wall_s"]
        for k in range(1, args.repeat + 1)
    ]
    first = next(iter(results.values()))
    case = {
        "case": name,
        "params": first.params,
        "grid": [list(g) for g in grid],
        "points": n_points,
        "transient": transient,
        "tile_size": args.tile_size,
        "runs": runs,
        "processes_over_dask": ratios,
        "labels_agree": all(np.array_equal(first.labels, r.labels) for r in results.values()),
        "capture_agree": all(np.array_equal(first.capture, r.capture) for r in results.values()),
        "attractors": first.to_dict()["attractors"],
        "boundary_fraction": first.stats["boundary_fraction"],
        "refined": first.stats["refined"],
        "changed": first.stats["changed"],
        "load_average_1_5_15_at_end": list(os.getloadavg()),
    }
    return case, first


def _breakdown_lines(c: dict) -> list[str]:
    """The Dask runs' breakdown (task stream) and the processes / Dask wall-time ratios."""
    lines = [
        "Dask breakdown (scheduler task stream; seconds): tasks, compute per worker, first task "
        "per worker, mean task, deserialize, transfer, idle = workers x wall - busy (the "
        "driver's own steps: client, labelling, the refinement's set-up):",
        "",
        "| run | wall | tasks | compute per worker | first task | mean task | deserialize "
        "| transfer | idle | strobe kernel per worker: cache hits, compilations, preload [s] "
        "| load (1 min) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, r in c["runs"].items():
        b = r.get("breakdown")
        if b is None:
            continue
        lines.append(
            f"| {name} | {r['wall_s']:.1f} | {b['tasks']} | "
            + ", ".join(f"{x:.1f}" for x in b["compute_s_per_worker"])
            + " | "
            + ", ".join(f"{x:.2f}" for x in b["first_task_s"])
            + f" | {b['mean_task_s']:.3f} | {b['deserialize_s']:.3f} | {b['transfer_s']:.3f} "
            f"| {b['idle_s']:.1f} | "
            + "; ".join(
                f"{h}, {m}, " + ("-" if w is None else f"{w:.2f}")
                for h, m, w in b["strobe_cache_hits_misses_per_worker"]
            )
            + f" | {r['load_average_1']:.2f} |"
        )
    lines += [
        "",
        "T_processes / T_dask, round by round (>= 0.9: Dask within 10 % of the local "
        "processes): "
        + ", ".join(f"{x:.3f}" for x in c["processes_over_dask"])
        + f"; median {statistics.median(c['processes_over_dask']):.3f} (this machine's speed moves "
        "by up to 20 % between rounds: each round's pair runs back to back).",
        "",
    ]
    return lines


def _table(c: dict) -> list[str]:
    p = c["params"]
    lines = [
        f"## {c['case']}: eta={p['eta']} zeta={p['zeta']} R={p['R']} x_w={p['x_w']} a={p['a']}",
        "",
        f"{c['grid'][0][2]} x {c['grid'][1][2]} = {c['points']} points on the impact surface, "
        f"transient {c['transient']} periods, tiles of {c['tile_size']}.",
        "",
        "| run | workers | wall [s] | time/point [us] | efficiency | worker peak RSS [MiB] |",
        "|---|---|---|---|---|---|",
    ]
    for name, r in c["runs"].items():
        eff = "-" if r["efficiency"] is None else f"{r['efficiency']:.2f}"
        rss = r.get("worker_peak_rss_MiB", "-")
        if isinstance(rss, list):
            rss = ", ".join(f"{x:.0f}" for x in rss)
        elif isinstance(rss, float):
            rss = f"{rss:.0f}"
        lines.append(
            f"| {name} | {r['workers']} | {r['wall_s']:.1f} | {r['time_per_point_us']:.1f} "
            f"| {eff} | {rss} |"
        )
    lines += [
        "",
        f"Labels identical across the runs: {c['labels_agree']} (capture counts: "
        f"{c['capture_agree']}).  Attractors: "
        + ", ".join(f"{a['name']} ({a['points']} points)" for a in c["attractors"])
        + f"; {c['refined']} boundary points re-run with 10x the transient ({c['changed']} "
        f"changed), boundary fraction {c['boundary_fraction']:.4f}.  Load average at the end "
        + ", ".join(f"{x:.2f}" for x in c["load_average_1_5_15_at_end"])
        + ".",
        "",
    ]
    return lines


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=1000, help="chatter: points per axis (default 1000)")
    ap.add_argument("--n-paper", type=int, default=200, help="paper: points per axis (default 200)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--dask-workers", type=int, default=2)
    ap.add_argument("--tile-size", type=int, default=2000)
    ap.add_argument("--skip-serial", action="store_true")
    ap.add_argument("--repeat", type=int, default=2, help="rounds of processes + Dask")
    args = ap.parse_args()
    chatter = Params.make(eta="4.85", zeta=0, R="0.5", x_w="-0.3", x0="-0.5")
    paper = Params.make(eta="0.74")
    basins(chatter, ((0, 1, 4), (0, 0.6, 4)), transient=5, progress=False)  # compile once
    cases, figs = [], []
    for name, params, grid, transient in (
        ("chatter", chatter, ((0, 1, args.n), (0, 0.6, args.n)), 60),
        ("paper", paper, ((0, 1, args.n_paper), (0, 3, args.n_paper)), 100),
    ):
        case, first = run_case(name, params, grid, transient, args)
        cases.append(case)
        figs.append(first)
    report = {
        "cpus": os.cpu_count(),
        "driver_peak_rss_MiB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "cases": cases,
    }
    OUT.mkdir(exist_ok=True)
    text = json.dumps(report, indent=1, allow_nan=False)
    atomic_write(OUT / "basins.json", lambda fh: fh.write(text), binary=False)
    lines = [
        "# Domains of attraction at scale (bench_basins.py)",
        "",
        f"{os.cpu_count()} CPUs, shared with other jobs (see the load averages); efficiency = "
        "T_serial / (workers x T_run); Dask: a loopback `dask scheduler` + `dask worker` cluster "
        f"of single-threaded worker processes.  Driver peak RSS "
        f"{report['driver_peak_rss_MiB']:.0f} MiB.  Run: `python benchmarks/bench_basins.py "
        + " ".join(sys.argv[1:])
        + "`; processes and Dask alternate, `--repeat` rounds each, on one loopback cluster "
        "whose workers preload the package (benchmarks/dask_preload.py).",
        "",
    ]
    for c in cases:
        lines += _table(c) + _breakdown_lines(c)
    atomic_write(OUT / "basins.md", lambda fh: fh.write("\n".join(lines)), binary=False)
    figs[0].plot(OUT / "basins.png")
    figs[1].plot(OUT / "basins_paper.png")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
