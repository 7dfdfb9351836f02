"""The README's commands, run in order in a fresh directory, all succeed.

The commands are read from README.md's ``bash`` blocks (no copy here to go stale): every
``precise-impact ...`` line runs, in the order written, in one fresh working directory, so
that later commands meet the files earlier ones left (``reproduce --out results`` then
``run ... --out results``: refused before the output-directory contract, issue 27).  Set-up
lines (venv, pip, apt-get, the CI script) are recognised and left to
``scripts/test-installed.sh``; any other line fails the test, so a new README command is run
or explicitly classified.

After each command, every file it wrote into its ``--out`` directory must be one of the files
it declares (``add_out(writes=...)``): the declaration is what lets commands share a
directory, so a file written but not declared could be replaced silently by a second run.

``test_readme_sequence`` (slow) runs the commands as written, each in a new process.  The
default suite runs ``test_readme_sequence_quick``: the same lines with shorter runs (``QUICK``
below: fewer periods, smaller grids, one worker) through ``main()`` in this process;
``reproduce --quick`` and ``bench work-precision --quick`` (each over a minute on 2 busy
cores) are left to the slow variant (``bench`` without ``--json`` is covered through the
CLI in ``tests/cli/test_cli.py``), and ``reproduce``'s files are laid into ``results/``
first, so that the quick run meets the same shared directory.
"""

from __future__ import annotations

import contextlib
import fnmatch
import io
import json
import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

import pytest

from helpers import check_accuracy_outputs
from precise_impact.cli.main import build_parser, main
from precise_impact.io.lock import LOCK_NAME
from precise_impact.io.markdown import parse_tables
from precise_impact.verification.reproduce import OUTPUT_FILES

README = Path(__file__).resolve().parents[1] / "README.md"

#: Set-up commands of the README (first word, or first two): what scripts/test-installed.sh does.
SETUP = {
    ("python3", "-m"),  # python3 -m venv .venv
    (".", ".venv/bin/activate"),
    ("pip", "install"),
    ("apt-get", "update"),
    ("apt-get", "install"),
    ("bash", "scripts/test-installed.sh"),
}

#: The quick variant: (README command prefix, replacements of its arguments).  Fewer periods
#: and smaller grids, the same flags and outputs.
QUICK = {
    "simulate --eta 0.74 --periods 300": [("--periods 300", "--periods 10")],
    "certify --eta 0.712 --periods 300": [("--periods 300", "--periods 60")],
    "accuracy --out results": [("--out results", "--periods 5 --out results")],
    "compare fig5-chaotic-datasheet": [
        ("compare fig5-chaotic-datasheet", "compare fig5-chaotic-datasheet --periods 10")
    ],
    "sync --form first-order": [("--k 0.02 0.05 7", "--k 0.02 0.05 2 --periods 60 --ensemble 2")],
    "bifurcation --eta 0.68 0.82 400": [
        ("0.82 400", "0.82 4 --periods 40 --transient 40 --workers 1")
    ],
    "budget --sobol 64 --out results/budget": [
        ("--sobol 64 --out", "--landmarks grazing --mc 20 --sobol 0 --lle-mc 0 --no-scans --out")
    ],
    "impact-map --eta 0.712": [("--singularity", "--n 200 --singularity")],
    "basins --eta 4.85": [("0 1 200", "0 1 12"), ("0.6 150", "0.6 9")],
    "sweep --axis eta 0.68 0.82 100": [
        ("0.82 100", "0.82 3"),
        ("2.5 100", "2.5 3 --periods 40 --transient 40 --workers 1"),
    ],
}
#: Left to the slow variant (see the module docstring).
SLOW_ONLY = ("reproduce", "bench work-precision")


def readme_commands() -> list[str]:
    """Every command line of README.md's bash blocks, in order, split at ``&&``."""
    text = README.read_text(encoding="utf-8")
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for raw in block.replace("\\\n", " ").splitlines():
            line = raw.split(" #", 1)[0].strip()
            if line and not line.startswith("#"):
                lines += [c.strip() for c in line.split("&&")]
    return lines


def _is_setup(cmd: str) -> bool:
    words = shlex.split(cmd)
    return tuple(words[:2]) in SETUP


def _quick(cmd: str) -> str | None:
    rest = cmd.removeprefix("precise-impact ")
    if rest.startswith(SLOW_ONLY):
        return None
    for prefix, subs in QUICK.items():
        if rest.startswith(prefix):
            for a, b in subs:
                assert a in cmd, (a, cmd)
                cmd = cmd.replace(a, b)
    return cmd


def _out_dir(cmd: str, cwd: Path):
    """The command's parsed arguments (the CLI's own parser) and its ``--out`` directory."""
    argv = shlex.split(cmd.split(">", 1)[0])[1:]
    ns = build_parser().parse_args(argv)  # the README's commands have no negative values
    out = getattr(ns, "out", None)
    if out is None or getattr(ns, "out_kind", None) != "dir":
        return ns, None
    return ns, cwd / out


def _snapshot(d: Path | None) -> dict[str, float]:
    if d is None or not d.is_dir():
        return {}
    return {
        e.name: e.stat().st_mtime_ns for e in d.iterdir() if e.is_file() and e.name != LOCK_NAME
    }


#: The interpreter of a venv set up exactly as the README says (its ``pip install`` line, run
#: by scripts/test-installed.sh): the slow sequence runs the commands there, so an example
#: that needs a package the README's set-up does not install fails (issue 35 item 7a).
README_PYTHON = os.environ.get("PRECISE_IMPACT_README_PYTHON")


def _python() -> str:
    return README_PYTHON or sys.executable


def _env() -> dict[str, str]:
    env = dict(os.environ)
    if not os.environ.get("PRECISE_IMPACT_TEST_INSTALLED"):
        src = str(Path(__file__).resolve().parents[1] / "src")
        env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _run_in_process(cmd: str, cwd: Path) -> tuple[int, str]:
    """``main()`` on the command's words in ``cwd``; ``> FILE`` receives standard output."""
    words, _, target = cmd.partition(">")
    argv = shlex.split(words)[1:]
    out, err = io.StringIO(), io.StringIO()
    old = os.getcwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            status = main(argv)
    finally:
        os.chdir(old)
    if target.strip():
        (cwd / target.strip()).write_text(out.getvalue(), encoding="utf-8")
    return status, err.getvalue()


def _run_server(cmd: str, cwd: Path) -> tuple[int, str]:
    """``precise-impact explore ...`` as written: its page and its JSON API answer on the
    port it names, then Ctrl-C ends it (status 0 for the sequence when it exits 130 with one
    line; its stderr otherwise)."""
    import signal  # noqa: PLC0415 -- this helper alone
    import urllib.request  # noqa: PLC0415 -- this helper alone

    port = re.search(r"--port (\d+)", cmd).group(1)
    p = subprocess.Popen(
        shlex.split(cmd), cwd=cwd, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    answered = None
    deadline = time.monotonic() + 120
    while answered is None and time.monotonic() < deadline and p.poll() is None:
        try:
            with urllib.request.urlopen(
                f"http://127.0.0.1:{port}/api/orbit?periods=3", timeout=5
            ) as r:
                answered = json.loads(r.read())["view"] == "orbit"
        except OSError:
            time.sleep(0.5)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    lines = [
        x
        for x in err.splitlines()
        if x.strip() and not x.startswith(("Launching", "precise-impact explore:"))
    ]
    ok = answered and p.returncode == 130 and len(lines) == 1
    return (0 if ok else p.returncode or 1), err


def _run_sequence(
    tmp_path: Path, quick: bool, stdouts: dict[str, str] | None = None
) -> list[tuple[str, float]]:
    """Each command's seconds, in order; ``stdouts`` (when given) receives each subprocess
    command's standard output."""
    cmds = readme_commands()
    unknown = [c for c in cmds if not c.startswith("precise-impact ") and not _is_setup(c)]
    assert not unknown, f"README commands neither run here nor set-up: {unknown}"
    exe = f"{shlex.quote(_python())} -m precise_impact"
    timings = []
    if quick:  # the files reproduce leaves in results/, which later commands share
        (tmp_path / "results").mkdir()
        for pat in OUTPUT_FILES:
            name = pat.replace("[456]", "4").replace("*", "first-order")
            (tmp_path / "results" / name).write_text("from reproduce\n")
    for cmd in cmds:
        if _is_setup(cmd):
            continue
        run = _quick(cmd) if quick else cmd
        if run is None:
            continue
        ns, out = _out_dir(run, tmp_path)
        before = _snapshot(out)
        t0 = time.perf_counter()
        if run.startswith("precise-impact explore"):  # a server: it answers, then Ctrl-C
            status, stderr = _run_server(exe + run.removeprefix("precise-impact"), tmp_path)
        elif quick:  # in this process: the same main(), without a new interpreter per line
            status, stderr = _run_in_process(run, tmp_path)
        else:
            r = subprocess.run(
                exe + run.removeprefix("precise-impact"),
                shell=True,
                cwd=tmp_path,
                env=_env(),
                capture_output=True,
                text=True,
                timeout=900,
            )
            status, stderr = r.returncode, r.stderr
            if stdouts is not None:
                stdouts[run] = r.stdout
        timings.append((run, time.perf_counter() - t0))
        assert status == 0, f"README command failed ({status}): {run}\n{stderr[-2000:]}"
        assert "Traceback" not in stderr, run
        if out is not None:
            written = [n for n, m in _snapshot(out).items() if before.get(n) != m]
            assert written, f"{run}: wrote nothing into {out}"
            writes = ns.out_writes(ns) if callable(ns.out_writes) else ns.out_writes
            undeclared = [n for n in written if not any(fnmatch.fnmatchcase(n, p) for p in writes)]
            assert not undeclared, f"{run}: wrote {undeclared}, not in its declared {writes}"
    return timings


def test_readme_commands_are_known():
    """Every README command line is either run by the sequence test or a recognised set-up."""
    cmds = readme_commands()
    assert any(c.startswith("precise-impact reproduce") for c in cmds)
    assert len([c for c in cmds if c.startswith("precise-impact ")]) >= 10
    for c in cmds:
        assert c.startswith("precise-impact ") or _is_setup(c), c
    for prefix in QUICK:  # every quick replacement still applies to a README command
        assert any(c.startswith("precise-impact " + prefix) for c in cmds), prefix


@pytest.mark.covered_by("tests/test_readme_sequence.py::test_readme_sequence")
def test_readme_sequence_quick(tmp_path):
    timings = _run_sequence(tmp_path, quick=True)
    print("\n".join(f"{t:7.1f} s  {c}" for c, t in timings))
    assert len(timings) >= 8
    # the files reproduce leaves were not replaced by any other command
    assert (tmp_path / "results" / "report.md").read_text() == "from reproduce\n"


def _name(requirement: str) -> str:
    """A requirement's distribution name, normalised (PEP 503)."""
    return re.sub(r"[-_.]+", "-", re.split(r"[<>=!~\[ ;]", requirement, maxsplit=1)[0]).lower()


def _extra_packages(extras: set[str] | None = None) -> set[str]:
    """The distributions named by pyproject's extras (all of them by default)."""
    import tomllib

    table = tomllib.loads((README.parent / "pyproject.toml").read_text(encoding="utf-8"))
    opt = table["project"]["optional-dependencies"]
    names = set()
    for extra, deps in opt.items():
        if extras is None or extra in extras:
            names |= {re.split(r"[<>=!~\[ ;]", d, maxsplit=1)[0].lower() for d in deps}
    core = {
        re.split(r"[<>=!~\[ ;]", d, maxsplit=1)[0].lower() for d in table["project"]["dependencies"]
    }
    return names - core


#: Run in the README's venv: each installed distribution and what it requires unconditionally
#: (a requirement behind ``extra == ...`` is not installed by the bare package), names
#: normalised as pyproject's.
_LIST_DISTRIBUTIONS = """
import json, re, importlib.metadata as m
def norm(n):
    return re.sub(r"[-_.]+", "-", n).lower()
out = {}
for d in m.distributions():
    reqs = [r for r in (d.requires or []) if "extra ==" not in r]
    names = [re.split(r"[<>=!~\\[ ;(]", r, maxsplit=1)[0] for r in reqs]
    out[norm(d.metadata["Name"])] = [norm(n) for n in names]
print(json.dumps(out))
"""


def _readme_extras() -> set[str]:
    """The extras of the README's ``pip install -e '.[...]'`` set-up line."""
    pips = [c for c in readme_commands() if c.startswith("pip install -e")]
    assert len(pips) == 1, pips
    m = re.search(r"\.\[([^\]]*)\]", pips[0])
    return {e.strip() for e in m.group(1).split(",")} if m else set()


@pytest.mark.slow  # beside the sequence, once scripts/test-installed.sh has made the venv
@pytest.mark.skipif(
    README_PYTHON is None, reason="needs the README's venv (scripts/test-installed.sh)"
)
def test_the_readme_venv_holds_only_what_the_readme_installs():
    """The venv the slow sequence runs in is the README's: the packages of its extras are in
    it and those of the other extras (pytest, dask, ...) are not, or it hides a missing one."""
    out = subprocess.run(
        [README_PYTHON, "-c", _LIST_DISTRIBUTIONS], capture_output=True, text=True, check=True
    )
    installed = json.loads(out.stdout)
    have = set(installed)
    required = {r for reqs in installed.values() for r in reqs}  # by an installed package
    wanted = _extra_packages(_readme_extras())
    others = _extra_packages() - wanted
    assert wanted <= have, wanted - have
    # another extra's package is there only as a dependency (SALib requires pandas: fine)
    assert not (others & have) - required, (others & have) - required


def _check_main_job(out: Path) -> None:
    """What the README's first command, ``reproduce --quick``, left in ``out``: report.md with
    every figure, the LLE and the sync thresholds (checked on the sequence's own run, not a
    second run of the main job: ~50 s each on 2 cores)."""
    rep = json.loads((out / "report.json").read_text())
    assert set(rep["figures"]) == {"4", "5", "6"}
    for fig in ("4", "6"):  # periodic: the ideal circuit model equals the reference to round-off
        assert rep["figures"][fig]["models"]["circuit (ideal)"]["max_error_second_half"] < 1e-10
        assert rep["figures"][fig]["demonstrated"] < 1e-40
    v = rep["lle"]["variational"]
    assert abs(v[0] - 0.0305) < 5 * v[1] + 1e-3
    assert set(rep["sync"]) == {"first-order", "reduced", "paper"}
    md = (out / "report.md").read_text()
    assert "Largest Lyapunov exponent" in md and "Fig. 6" in md
    assert len(parse_tables(md)) >= 4  # Figs. 4-6 and the thresholds at least; each renders
    # every run's attractor; the datasheet circuit on another one at Figs. 4 and 6, explained
    for fig, verdict in (("4", "another attractor"), ("6", "another attractor")):
        att = rep["figures"][fig]["attractors"]
        ds = att["models"]["switched-capacitor (datasheet)"]
        assert ds["same_as_mechanics"] == verdict and ds["effective"]["explains"], fig
        assert att["models"]["circuit (ideal)"]["same_as_mechanics"] == "same"
    assert md.count("so the shifts explain it") == 3 and md.count("Attractors (") == 3
    for name in ("fig4_phase_portraits.png", "fig7_first-order.png", "sync_fraction_paper.png"):
        assert (out / name).stat().st_size > 5000


@pytest.mark.slow  # reproduce --quick and bench work-precision --quick: minutes in all
def test_readme_sequence(tmp_path):
    outputs: dict[str, str] = {}
    timings = _run_sequence(tmp_path, quick=False, stdouts=outputs)
    print("\n".join(f"{t:7.1f} s  {c}" for c, t in timings))
    print(f"{sum(t for _, t in timings):7.1f} s  in all")
    main_job = [c for c, _ in timings if c.startswith("precise-impact reproduce --quick")]
    assert main_job == ["precise-impact reproduce --quick --out results"], main_job
    _check_main_job(tmp_path / "results")
    # the accuracy job's outputs, as tests/cli/test_cli.py::test_accuracy_job checks them (it is
    # left out of a session that runs this test)
    accuracy = [c for c, _ in timings if c.startswith("precise-impact accuracy")]
    assert accuracy == ["precise-impact accuracy --out results"], accuracy
    check_accuracy_outputs(tmp_path / "results", outputs["precise-impact accuracy --out results"])
    # a second run of the main job into the same directory is refused, naming its own file
    r = subprocess.run(
        [_python(), "-m", "precise_impact", "reproduce", "--quick", "--out", "results"],
        cwd=tmp_path,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    named = re.search(r"it holds (\S+),", r.stderr)
    assert r.returncode == 2 and named, r.stderr
    assert any(fnmatch.fnmatchcase(named.group(1), p) for p in OUTPUT_FILES), r.stderr
