"""Suite-wide checks: what is under test, and which precisions this heyoka build has.

* ``PRECISE_IMPACT_TEST_INSTALLED=1`` (set by ``scripts/test-installed.sh``): the
  package must be imported from the installed wheel, never from the checkout, so a
  file missing from the wheel fails the suite instead of being found in ``src/``.
* heyoka builds without quad precision (no ``heyoka.real128``: macOS, ARM, some
  PyPI wheels) skip the float128 cases with one stated reason; everything else
  runs.  The package itself refuses float128 there with a ParameterError
  (tested in ``test_packaging.py``).
"""

from __future__ import annotations

import inspect
import os
from pathlib import Path

import heyoka
import pytest

import precise_impact

HAVE_QUAD = hasattr(heyoka, "real128")
CHECKOUT = Path(__file__).resolve().parents[1]


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


def pytest_collection_modifyitems(config, items):
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
