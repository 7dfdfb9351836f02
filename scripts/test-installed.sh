#!/usr/bin/env bash
# Test what users install.  Builds the wheel from the files git knows (tracked, or new and
# not ignored: no stale build/ directory can leak into it), checks that every file of the
# package (the top-level reference_data/** as precise_impact/data/reference/, scenes/*.toml,
# py.typed) is in it, installs it
# non-editable with the extras [test,dask,bench,docs,explore] into a fresh venv outside the
# checkout and, from a directory outside the checkout, runs:
#   ruff check, ruff format --check and mypy on the sources (zero findings),
#   precise-impact --version, precise-impact reference verify, the README's testing example
#   (the code block itself, read from README.md), the whole test suite against the installed
#   package in one pytest run: the default suite and the slow tests (-m slow: long
#   references, coverage statistics, the README's commands in order, ten signals per long
#   command) but the ~10-minute hypothesis long run, with a venv set up exactly as the README
#   says (its `pip install -e '.[...]'` line) in which the slow README-sequence test runs the
#   README's commands.
# With --ci (what .ci/run adds): then the lowest declared dependency versions
# (.ci/lowest-constraints.txt) in a second venv run a fast subset, with the documentation build
# (html and doctest, warnings are errors) beside them.  The README's venv (and the lowest-version
# venv) are set up in the background from the moment the wheel is built (pip waits on the
# network and the disk, not the cores).  Every step is timed.
#
# Usage: bash scripts/test-installed.sh [--ci]  (from anywhere; needs python3 >= 3.11 with venv)
# Env:   PYTHON=python3.12 to pick the interpreter; KEEP=1 keeps the work directory;
#        WORKERS=N test processes (default: one per core).
set -euo pipefail
ci=0
case "${1:-}" in
  --ci) ci=1 ;;
  "") ;;
  *) echo "scripts/test-installed.sh: unknown argument '$1' (allowed: --ci)"; exit 2 ;;
esac
# bytecode is written (a machine may set PYTHONDONTWRITEBYTECODE=1): pytest's rewritten test
# modules and the README venv's editable sources are compiled once, not in every process
# (measured: collecting the suite 14.9 s without the cache, 5.0 s with it, in each process)
unset PYTHONDONTWRITEBYTECODE
repo=$(cd "$(dirname "$0")/.." && pwd)
py=${PYTHON:-python3}
work=$(mktemp -d "${TMPDIR:-/tmp}/precise-impact-test.XXXXXX")
# background steps (below) end with the script, whatever ends it
if [ "${KEEP:-0}" = 1 ]; then
  echo "   work directory kept: $work"; trap 'kill $(jobs -p) 2>/dev/null || true' EXIT
else
  trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$work"' EXIT
fi
t_all=$SECONDS
t=$SECONDS
step() { echo "== $* ($(date +%T))"; t=$SECONDS; }
took() { echo "   ($((SECONDS - t)) s)"; }

# pip runs with --no-compile everywhere: compiling every installed module's bytecode (scipy's,
# pandas', sphinx's, ... most never imported here) took 45 of the main install's 62 s of CPU
# (74 s -> 26 s wall in a quiet venv); the modules imported are compiled once on first import
step "fresh venv outside the checkout: $work/venv"
"$py" -m venv "$work/venv"
vpy="$work/venv/bin/python"
"$vpy" -m pip install -q --no-compile --upgrade pip
took

step "building the wheel"
mkdir -p "$work/src"
if git -C "$repo" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  (cd "$repo" && git ls-files -z --cached --others --exclude-standard \
     | while IFS= read -r -d '' f; do [ -e "$f" ] && printf '%s\0' "$f"; done \
     | xargs -0 cp --parents -t "$work/src")
else
  (cd "$repo" && tar --exclude=.venv --exclude=build --exclude='*.egg-info' --exclude=__pycache__ -cf - .) \
    | tar -xf - -C "$work/src"
fi
"$vpy" -m pip wheel -q --no-deps -w "$work/dist" "$work/src"
wheel=$(ls "$work/dist"/precise_impact-*.whl)
echo "   $(basename "$wheel"): $(du -k "$wheel" | cut -f1) KiB"
"$vpy" - "$wheel" "$work/src" <<'PY'
import pathlib, sys, zipfile
wheel, top = sys.argv[1], pathlib.Path(sys.argv[2])
names = set(zipfile.ZipFile(wheel).namelist())
def files(root, prefix):
    return {prefix + p.relative_to(root).as_posix() for p in root.rglob("*")
            if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"}
# the package's sources, and the repository's one copy of the reference datasets (reference_data/),
# which the wheel installs as precise_impact/data/reference/
want = files(top / "src" / "precise_impact", "precise_impact/") | files(top / "reference_data", "precise_impact/data/reference/")
missing = sorted(want - names)
if missing:
    sys.exit("files of the package missing from the wheel:\n  " + "\n  ".join(missing))
data = sorted(n for n in want if n.startswith("precise_impact/data/"))
print(f"   all {len(want)} package files are in the wheel ({len(data)} under precise_impact/data/)")
PY
took

# Two venvs that later steps need are set up in the background while the main venv installs and
# the default suite runs: pip's downloads and unpacking wait on the network and the disk, not on
# the cores.
bg() {  # bg NAME COMMAND...: run in the background, its output and time in $work/NAME.log
  local name=$1; shift
  ( t0=$SECONDS; "$@" >"$work/$name.log" 2>&1; rc=$?; echo "   ($((SECONDS - t0)) s)" >>"$work/$name.log"; exit $rc ) &
  eval "pid_$name=$!"
}
wait_bg() {  # wait_bg NAME: its log, and its status
  local name=$1 pid; eval "pid=\$pid_$name"
  if ! wait "$pid"; then cat "$work/$name.log"; echo "background step $name failed"; exit 1; fi
  cat "$work/$name.log"
}

# numba's compiled kernels, compiled once into the installed package's cache in the background
# (beside the single-threaded static checks): with a cold cache each test process, and each
# worker of a test's CLI run, compiled the same kernels at once (~40 s of CPU each) at the start
# of the suite
warm_kernels() {  # warm_kernels PYTHON
  (cd "$work" && "$1" - <<'PY'
import time
t = time.perf_counter()
import precise_impact as pi
p = pi.Params.make(eta="0.712")
pi.simulate(p, 3, model="fast")
pi.lyapunov(p, model="fast", periods=20)
pi.simulate_coupled(p, "0.1", periods=3, model="fast")
chatter = pi.Params.make(eta="4.85", zeta=0, R="0.5", x_w="-0.3", x0="-0.5")
pi.impact_map(chatter, 0.5, 0.3, 3, engine="fast")
pi.basins(chatter, ((0, 1, 2), (0.1, 0.6, 2)), transient=5, progress=False)
print(f"   compiled kernels in {time.perf_counter() - t:.1f} s")
PY
  )
}

# a venv set up exactly as the README says (its pip install line, run in a copy of the checkout
# of its own: the editable install writes its metadata there): the slow README-sequence test runs
# the README's commands with this venv's interpreter, so an example needing a package the
# README's set-up does not install fails there (issue 35 item 7a)
readme_pip=$(grep -Eo "pip install -e '[^']*'" "$repo/README.md" | head -n 1)
[ -n "$readme_pip" ] || { echo "no 'pip install -e' line in README.md"; exit 1; }
readme_venv() {
  echo "   $readme_pip"
  cp -a "$work/src" "$work/readme-src"
  "$py" -m venv "$work/readme"
  "$work/readme/bin/python" -m pip install -q --no-compile --upgrade pip
  (cd "$work/readme-src" && eval "\"$work/readme/bin/python\" -m $readme_pip -q --no-compile")
  # its compiled kernels too, into its own checkout's cache, as for the main venv: the README's
  # first commands compiled them under the suite's load (~45 s of CPU, measured 446 s for the
  # sequence in CI against 315 s with a warm cache)
  warm_kernels "$work/readme/bin/python"
}
bg readme_venv readme_venv

# (--ci) the lowest declared dependency versions (.ci/lowest-constraints.txt), for a fast subset
# at the end
lowest_venv() {
  "$py" -m venv "$work/lowest"
  "$work/lowest/bin/python" -m pip install -q --no-compile --upgrade pip
  "$work/lowest/bin/python" -m pip install -q --no-compile -c "$repo/.ci/lowest-constraints.txt" "${wheel}[test,dask,bench]"
  "$work/lowest/bin/python" - "$repo/.ci/lowest-constraints.txt" <<'PY'
import sys
from importlib.metadata import version
pins = [l.split("==") for l in open(sys.argv[1]) if "==" in l and not l.startswith("#")]
wrong = [(n, v.strip(), version(n)) for n, v in pins if version(n) != v.strip()]
if wrong:
    sys.exit(f"not the lowest versions: {wrong}")
print("   installed:", ", ".join(f"{n} {v.strip()}" for n, v in pins))
PY
  warm_kernels "$work/lowest/bin/python"  # once here, not in each test process (~40 s each)
}
if [ "$ci" = 1 ]; then bg lowest_venv lowest_venv; fi

step "installing it (non-editable) with [test,dask,bench,docs,explore]"
"$vpy" -m pip install -q --no-compile "${wheel}[test,dask,bench,docs,explore]"
took

bg warm_kernels warm_kernels "$vpy"

step "the static checks' tools (the [lint] extra: pinned ruff and mypy)"
"$vpy" -m pip install -q --no-compile "${wheel}[lint]"   # not beside the tests: pip changes the venv they import from
took
static_checks() {  # ruff check, ruff format --check, mypy (zero findings)
  cd "$work/src" && "$work/venv/bin/ruff" check --no-cache . && "$work/venv/bin/ruff" format --check --no-cache . \
    && "$work/venv/bin/mypy" --no-incremental
}
# beside the kernels' compilation and then the test suite, at the lowest priority: the static
# checks (and, with --ci, the documentation build) take the cores' idle moments (5 % of the
# suite's, waiting on its subprocesses) instead of a step of their own (21 s; docs 182 s)
bg static static_checks
renice -n 19 -p "$pid_static" >/dev/null

mkdir -p "$work/run" && cd "$work/run"   # outside the checkout: nothing is imported from src/
export PATH="$work/venv/bin:$PATH"
echo "== $(precise-impact --version) from $(python -c 'import precise_impact, os; print(os.path.dirname(precise_impact.__file__))')"

step "precise-impact reference verify (shipped datasets: checksums, a recomputed subset)"
precise-impact reference verify
took

step "the README's testing example (the code block in README.md)"
python - "$repo/README.md" <<'PY'
import re, sys
text = open(sys.argv[1], encoding="utf-8").read()
blocks = [b for b in re.findall(r"```python\n(.*?)```", text, re.S) if "assert_stroboscopic_close(" in b]
if len(blocks) != 1:
    sys.exit(f"expected one README code block with assert_stroboscopic_close, found {len(blocks)}")
exec(compile(blocks[0], "README.md", "exec"), {"__name__": "__main__"})
print("   passed")
PY
took

step "the compiled kernels (compiled in the background since the install)"
wait_bg warm_kernels
took

step "the README's venv (set up in the background since the wheel was built)"
wait_bg readme_venv
export PRECISE_IMPACT_README_PYTHON="$work/readme/bin/python"
took

docs() {  # html and doctest (warnings are errors, every example executed, every figure made)
  # one doctree directory for both builders: the doctest build reuses the html build's parse
  # (the figures of docs/_ext/docfigures are made once)
  if ! sphinx-build -W --keep-going -b html -d "$work/docs/doctrees" "$repo/docs" "$work/docs/html" \
       >"$work/docs-html.log" 2>&1; then
    cat "$work/docs-html.log"; return 1
  fi
  grep -E "^docfigures:" "$work/docs-html.log" || true     # the figures' count and seconds
  if grep -q "sphinx.ext.doctest" "$repo/docs/conf.py"; then
    sphinx-build -q -W --keep-going -b doctest -d "$work/docs/doctrees" "$repo/docs" "$work/docs/doctest" || return 1
  fi
  # the pages work offline: no script or stylesheet from another host (MathJax is bundled)
  python - "$work/docs/html" <<'PY'
import pathlib, re, sys
bad = []
for page in sorted(pathlib.Path(sys.argv[1]).rglob("*.html")):
    for tag in re.findall(r"<(?:script|link)\b[^>]*>", page.read_text(encoding="utf-8")):
        bad += [f"{page.name}: {u}" for u in re.findall(r'(?:src|href)="([^"]*)"', tag)
                if re.match(r"(?:[a-z]+:)?//", u, re.I)]
if bad:
    sys.exit("pages load remote scripts or stylesheets:\n  " + "\n  ".join(bad))
print(f"   no remote scripts or stylesheets in {len(list(pathlib.Path(sys.argv[1]).rglob('*.html')))} pages")
PY
}
if [ "$ci" = 1 ] && [ -f "$repo/docs/conf.py" ]; then
  bg docs docs
  renice -n 19 -p "$pid_docs" >/dev/null
fi

step "the test suite against the installed package: the default suite and the slow tests, in one run"
# slow: long references, coverage statistics, the README's commands in order in the README's venv,
# ten signals per long command; all but the hypothesis long run (test_fuzz_long_run, ~10 min, a
# manual run).  One run, longest first (tests/durations.json), handed out one test at a time
# (--maxschedchunk 1): pytest-xdist's default hands each worker a quarter of its share at once, in
# order, so one worker held every long test while the others went idle (in the slow step: 15 % of
# the cores idle, user+sys 1202 s of 2 x 711 s; a run of both suites at 89 % had one of three
# workers busy for minutes).  Processes: WORKERS (default: one per core); the 20 slowest tests
# are listed at the end.
workers=${WORKERS:-$(nproc)}
PRECISE_IMPACT_TEST_INSTALLED=1 python -m pytest "$repo/tests" -p no:cacheprovider -n "$workers" \
  --maxschedchunk 1 --durations=20 --rootdir "$repo" -c "$repo/pyproject.toml" -m "slow or not slow" \
  -k "not fuzz_long_run" 2>&1 | tee "$work/pytest.log"
# pyproject's settings read (its markers; addopts -m 'not slow' for a plain run), not pytest's defaults
grep -q "configfile: pyproject.toml" "$work/pytest.log" || { echo "pytest did not read pyproject.toml"; exit 1; }
# (pytest-xdist's summary leaves out the deselected count: a collection in this process says it)
python -m pytest "$repo/tests" -p no:cacheprovider --collect-only -q --rootdir "$repo" \
  -c "$repo/pyproject.toml" 2>&1 | grep -Eq "[0-9]+ deselected" \
  || { echo "addopts -m 'not slow' was not applied"; exit 1; }
took

step "static checks: ruff check, ruff format --check, mypy (zero findings; run beside the suite)"
wait_bg static
took


if [ "$ci" = 1 ]; then
step "lowest declared dependency versions (venv set up in the background): $(grep -v '^#' "$repo/.ci/lowest-constraints.txt" | tr '\n' ' ')"
wait_bg lowest_venv
# (not the layering test: it reads the sources' AST, no dependency's version enters it (12 s))
PRECISE_IMPACT_TEST_INSTALLED=1 "$work/lowest/bin/python" -m pytest -p no:cacheprovider -n auto \
  --rootdir "$repo" -c "$repo/pyproject.toml" -q \
  "$repo/tests/core/test_params.py" "$repo/tests/solvers/test_heyoka_reference.py" "$repo/tests/solvers/test_closed_form.py" \
  "$repo/tests/analysis/test_variational.py" "$repo/tests/test_threads.py" "$repo/tests/verification/test_reference_data.py" \
  "$repo/tests/test_api.py" "$repo/tests/test_packaging.py" \
  "$repo/tests/analysis/test_sweep.py" "$repo/tests/verification/test_workprecision.py" "$repo/tests/solvers/test_fast.py" \
  "$repo/tests/solvers/test_coupled_fast.py" "$repo/tests/solvers/test_certified.py"
took
fi


if [ "$ci" = 1 ] && [ -f "$repo/docs/conf.py" ]; then
  step "documentation: html and doctest (warnings are errors, every example executed, every figure made; built beside the steps above)"
  wait_bg docs
  took
fi

echo "== all checks passed in $((SECONDS - t_all)) s"
