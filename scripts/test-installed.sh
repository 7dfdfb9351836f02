#!/usr/bin/env bash
# Test what users install: build the wheel, install it (non-editable) into a fresh venv outside
# the checkout, and from a directory outside the checkout run the whole test suite against the
# installed package, `precise-impact reference verify`, the README's testing example and the
# documentation build (warnings are errors; the docs' examples are executed).  Then the
# lowest declared dependency versions (ci/lowest-constraints.txt) get a fast subset.
#
# Usage: bash scripts/test-installed.sh        (from anywhere; needs python3 >= 3.11, pip, venv)
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/precise-impact-test.XXXXXX")
trap 'rm -rf "$work"' EXIT
echo "== building the wheel"
python3 -m venv "$work/build" && "$work/build/bin/pip" install -q --upgrade pip build >/dev/null
"$work/build/bin/python" -m build --wheel --outdir "$work/dist" "$repo" >/dev/null
wheel=$(ls "$work/dist"/precise_impact-*.whl)
echo "   $(basename "$wheel") ($(du -k "$wheel" | cut -f1) KiB)"

echo "== installing it into a fresh venv: $work/venv"
python3 -m venv "$work/venv"
. "$work/venv/bin/activate"
pip install -q --upgrade pip >/dev/null
pip install -q "${wheel}[test,dask,bench,docs]"

cd "$work"   # outside the checkout: nothing can be imported from src/
echo "== $(precise-impact --version) from $(python -c 'import precise_impact, os; print(os.path.dirname(precise_impact.__file__))')"
echo "== reference verify (shipped datasets, checksums + recomputation)"
precise-impact reference verify
echo "== the README's testing example"
python - <<'PY'
from precise_impact import Params, simulate
from precise_impact.testing import assert_stroboscopic_close

def my_solver(params, periods):            # params: exact decimal strings
    traj = simulate(Params.make(**params), periods, precision="float64")
    return traj.x, traj.v                    # x, v at t0 + k 2 pi / eta, k = 0..periods

assert_stroboscopic_close(my_solver, "single-0.74", periods=30, atol=1e-6, rtol=1e-6)
print("   testing example passed")
PY
echo "== the test suite against the installed package"
PRECISE_IMPACT_TEST_INSTALLED=1 python -m pytest "$repo/tests" -p no:cacheprovider --rootdir "$repo" -c "$repo/pyproject.toml"
if [ -f "$repo/docs/conf.py" ]; then
  echo "== documentation (warnings are errors; examples executed)"
  sphinx-build -q -W --keep-going -b html "$repo/docs" "$work/docs-html"
  sphinx-build -q -W --keep-going -b doctest "$repo/docs" "$work/docs-doctest"
fi
deactivate

echo "== lowest declared dependency versions ($(tr '\n' ' ' < "$repo/ci/lowest-constraints.txt"))"
python3 -m venv "$work/lowest"
"$work/lowest/bin/pip" install -q --upgrade pip >/dev/null
"$work/lowest/bin/pip" install -q -c "$repo/ci/lowest-constraints.txt" "${wheel}[test]"
PRECISE_IMPACT_TEST_INSTALLED=1 "$work/lowest/bin/python" -m pytest -p no:cacheprovider \
  --rootdir "$repo" -c "$repo/pyproject.toml" -q \
  "$repo/tests/test_params.py" "$repo/tests/test_reference.py" "$repo/tests/test_analytical.py" \
  "$repo/tests/test_variational.py" "$repo/tests/test_threads.py" "$repo/tests/test_reference_data.py" \
  "$repo/tests/test_api.py" "$repo/tests/test_layering.py"
echo "== all checks passed"
