"""Suite-wide checks: what is under test, and which precisions this heyoka build has.

* ``PRECISE_IMPACT_TEST_INSTALLED=1`` (set by ``scripts/test-installed.sh``): the
  package must be imported from the installed wheel, never from the checkout, so a
  file missing from the wheel fails the suite instead of being found in ``src/``.
* Long tests run first, longest first (``tests/durations.json``: seconds per test of a recorded
  run), so that pytest-xdist's workers do not end with one long test running alone while the
  others idle; ``PRECISE_IMPACT_RECORD_DURATIONS=1`` rewrites the table from a run's own times.
* heyoka builds without quad precision (no ``heyoka.real128``: macOS, ARM, some
  PyPI wheels) skip the float128 cases with one stated reason; everything else
  runs.  The package itself refuses float128 there with a ParameterError
  (tested in ``test_packaging.py``).
"""

from __future__ import annotations

import inspect
import json
import os
from pathlib import Path

import heyoka
import pytest

import precise_impact

HAVE_QUAD = hasattr(heyoka, "real128")
CHECKOUT = Path(__file__).resolve().parents[1]
DURATIONS_FILE = Path(__file__).resolve().with_name("durations.json")
#: Tests at least this long (seconds) are kept in the table; the others keep their order after.
RECORD_AT_LEAST_S = 1.0
_DURATIONS: dict[str, float] = (
    json.loads(DURATIONS_FILE.read_text(encoding="utf-8")) if DURATIONS_FILE.exists() else {}
)
_RECORDED: dict[str, float] = {}


try:  # the fuzzers (test_fuzz_api.py) draw new examples on every developer run; CI (CI=true)
    # replays one fixed derandomized sequence, so a landing never depends on the draw while each
    # defect a developer's run finds becomes a named regression test
    from hypothesis import settings as _hyp_settings

    _hyp_settings.register_profile("ci", derandomize=True, database=None)
    if os.environ.get("CI") == "true":
        _hyp_settings.load_profile("ci")
except ImportError:  # pragma: no cover - hypothesis is in the [test] extra
    pass


def pytest_report_header(config):
    return [
        f"precise_impact {precise_impact.__version__} from {Path(precise_impact.__file__).parent}",
        f"heyoka {heyoka.__version__}, quad precision: {'yes' if HAVE_QUAD else 'no'}",
    ]


def pytest_sessionstart(session):
    if os.environ.get("PRECISE_IMPACT_TEST_INSTALLED") == "1":
        where = Path(precise_impact.__file__).resolve()
        if CHECKOUT in where.parents:
            raise pytest.UsageError(
                f"PRECISE_IMPACT_TEST_INSTALLED=1 but precise_impact was imported from the "
                f"checkout ({where}), not from the installed wheel"
            )


@pytest.hookimpl(trylast=True)  # after -m and -k have deselected theirs
def pytest_collection_modifyitems(config, items):
    # longest first (a stable sort: the rest keep their order); pytest-xdist hands the first
    # quarter out round-robin and the rest to whichever worker is free
    items.sort(key=lambda item: -_DURATIONS.get(item.nodeid, 0.0))
    _leave_out_covered(config, items)
    if HAVE_QUAD:
        return
    skip = pytest.mark.skip(reason="this heyoka build has no quad precision (heyoka.real128)")
    for item in items:
        # A parametrized case needs quad if its id says so; any other test needs it
        # if its code asks for float128, unless it is marked to run without it.
        if item.get_closest_marker("without_quad"):
            continue
        if hasattr(item, "callspec"):
            needs = "float128" in item.nodeid
        else:
            try:
                needs = "float128" in inspect.getsource(item.function)
            except (OSError, TypeError):
                needs = False
        if needs:
            item.add_marker(skip)


def _leave_out_covered(config, items) -> None:
    """A default-suite test marked ``covered_by(SLOW_TEST)`` is deselected when that slow test
    runs in the same session (CI's one run of both suites): the slow test checks all it checks,
    on the longer run (the README's commands quick and as written: 24 s saved)."""
    selected = {item.nodeid.split("[")[0] for item in items}
    covered = [
        item
        for item in items
        if (m := item.get_closest_marker("covered_by")) is not None and m.args[0] in selected
    ]
    if covered:
        config.hook.pytest_deselected(items=covered)
        items[:] = [item for item in items if item not in covered]


def pytest_runtest_logreport(report):
    if os.environ.get("PRECISE_IMPACT_RECORD_DURATIONS") == "1":
        _RECORDED[report.nodeid] = _RECORDED.get(report.nodeid, 0.0) + report.duration


def pytest_sessionfinish(session):
    """With ``PRECISE_IMPACT_RECORD_DURATIONS=1``: the run's long tests into the table (in the
    controlling process only: pytest-xdist's workers report to it)."""
    if os.environ.get("PRECISE_IMPACT_RECORD_DURATIONS") != "1" or hasattr(
        session.config, "workerinput"
    ):
        return
    table = dict(_DURATIONS)
    for nodeid, seconds in _RECORDED.items():
        table.pop(nodeid, None)
        if seconds >= RECORD_AT_LEAST_S:
            table[nodeid] = round(seconds, 1)
    ordered = dict(sorted(table.items(), key=lambda kv: (-kv[1], kv[0])))
    DURATIONS_FILE.write_text(json.dumps(ordered, indent=0) + "\n", encoding="utf-8")


@pytest.fixture(scope="session")
def dask_scheduler():
    """The address of one Dask ``LocalCluster`` shared by the tests that run on Dask: what
    ``dask='local'`` starts per call (2 single-threaded worker processes), started once per
    test process instead of once per run (3-5 s each; basins with ``dask='local'`` starts one
    per scan it makes).  ``dask='local'`` itself keeps its own test
    (tests/analysis/test_scan_dask.py::test_dask_tiles_equal_serial_and_compile_once)."""
    distributed = pytest.importorskip("distributed", reason="Dask is optional")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        yield cluster.scheduler_address
