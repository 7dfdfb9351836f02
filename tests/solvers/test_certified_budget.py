"""Issue 28, "every run is bounded": ``certify`` (single and pair) is priced before any work,
stops at its ``max_time``, and refuses at once a run whose bits are out of reach instead of
doubling them up to ``max_bits`` (before: ``certify --bits 64 --periods 100000`` exited 3 after
~475 s, with ``--k 0.5`` after ~980 s)."""

import time

import pytest

import precise_impact as pi
from precise_impact.core import budget
from precise_impact.errors import BudgetExceededError, CertificationError, OverBudgetError

pytest.importorskip("flint", reason="python-flint: pip install python-flint")
from precise_impact.solvers.certified import single  # noqa: E402
from test_reliability import cli, cli_in_process  # noqa: E402

#: The acceptance bound is 60 s; the refusal comes after ~0.3 s of work (a 64-bit and a
#: 128-bit attempt) plus the interpreter's start (~2.5 s on the loaded 2-core machine).
QUICK = 20


def _message_lines(stderr):
    """The lines that are not progress lines nor the ``--bits`` deprecation note."""
    return [
        ln
        for ln in stderr.strip().splitlines()
        if not ln.lstrip().startswith("certified periods") and "--bits is deprecated" not in ln
    ]


@pytest.mark.parametrize("extra", [[], ["--k", "0.5"]])
def test_certify_out_of_reach_exits_3_with_one_line_at_once(extra):
    """Chaotic eta = 0.712: the radius grows ~0.2 digits per period, so 100000 periods need
    ~7e4 bits; refused after the 128-bit attempt (136 proven periods), not after 8192 bits."""
    r, took = cli("certify", "--bits", "64", "--periods", "100000", *extra)
    lines = _message_lines(r.stderr)
    assert r.returncode == 3, r.stderr[-800:]
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr[-800:]
    assert "beyond max_bits = 8192" in lines[0] and "digits per period" in lines[0], lines[0]
    assert took < QUICK, took


def test_certify_max_time_refuses_before_work():
    """100000 periods at 64 bits are priced ~2 min (1.2 ms per period): over --max-time 1,
    refused before any work like every command's estimate (exit 3, one line naming both)."""
    code, err, took = cli_in_process(
        "certify", "--bits", "64", "--periods", "100000", "--max-time", "1"
    )
    lines = _message_lines(err)
    assert code == 3 and len(lines) == 1, err  # a budget: exit 3 (issue 28)
    assert "max_time = '1 s'" in lines[0] and "100000 certified periods at 64 bits" in lines[0]
    assert took < 1, took  # no period computed (one 64-bit period is ~0.3 ms, 1e5 are ~30 s)


def test_the_api_prices_certify_and_refuses_over_max_time():
    p = pi.Params.make()
    t = time.perf_counter()
    with pytest.raises(OverBudgetError, match="max_time") as e:
        pi.certify(p, 100_000, precision="mp:64", max_time=10)
    assert e.value.name == "max_time" and "100000 certified periods at 64 bits" in str(e.value)
    with pytest.raises(OverBudgetError, match="max_time"):
        pi.certify_coupled(p, "0.5", periods=100_000, precision="mp:256", max_time=10)
    with pytest.raises(OverBudgetError, match="max_time"):  # the automatic bits: the pilot's 128
        pi.certify(p, 100_000, max_time=10)
    assert time.perf_counter() - t < 1
    # the job is known to estimate_cost: bits-dependent, x5 for the pair off the diagonal
    c64 = budget.estimate_cost("certify", periods=1000, precision="mp:64")
    c8k = budget.estimate_cost("certify", periods=1000, precision="mp:8192")
    pair = budget.estimate_cost("certify", periods=1000, precision="mp:64", coupled=True)
    assert c64.seconds == pytest.approx(1.2) and c8k.seconds > 40 * c64.seconds
    assert pair.seconds == pytest.approx(5 * c64.seconds)
    # in budget: certified as before
    r = pi.certify(pi.Params.make(eta="0.74"), 5, precision="mp:128", max_time=60)
    assert r.periods == 5 and r.bits == 128


def test_the_budget_is_enforced_during_the_run(monkeypatch):
    """An estimate that is far too low (patched to 1 us per period) does not let a run
    overrun: the deadline, checked after every period, stops it at max_time = 1 s with a
    BudgetExceededError (the CLI: exit 3, one line), not a proof hours later."""
    monkeypatch.setattr(budget, "certify_seconds_per_period", lambda bits: 1e-6)
    p = pi.Params.make(eta="0.74")
    for run in (
        lambda: pi.certify(p, 100_000, precision="mp:1024", max_time=1),
        lambda: pi.certify_coupled(p, "0.5", periods=100_000, precision="mp:1024", max_time=1),
        # off the diagonal, eta = 0.712: ~20 ms per period at 4096 bits, a proof to ~period 500
        lambda: pi.certify_coupled(
            pi.Params.make(x0="0.1"),
            "0.5",
            periods=100_000,
            y0=("0.2", "0"),
            precision="mp:4096",
            max_time=1,
        ),
    ):
        t = time.perf_counter()
        with pytest.raises(BudgetExceededError, match="max_time = 1 s ran out") as e:
            run()
        assert not isinstance(e.value, OverBudgetError)
        assert time.perf_counter() - t < 3  # 1 s plus at most one period (~20 ms)
    code, err, _ = cli_in_process(
        "certify", "--eta", "0.74", "--periods", "100000", "--precision", "mp:1024",
        "--max-time", "1",
    )  # fmt: skip
    lines = _message_lines(err)
    assert code == 3 and len(lines) == 1 and "ran out" in lines[0], err


def _partial(params, bits, periods):
    """The samples a failed attempt proved, as its CertificationError carries them."""
    with single.working_bits(bits):
        samples, _, _ = single.run_balls(params, periods, bits)
    e = CertificationError("no proof")
    e.partial = samples
    return e


def test_out_of_reach_needs_positive_growth_over_enough_periods():
    """The projection refuses only a growth measured over >= 100 proven periods and > 0."""
    chaotic = pi.Params.make()  # eta = 0.712: ~0.2 digits per period
    assert single.out_of_reach(_partial(chaotic, 256, 200), 256, 100_000, 8192) is not None
    # the same growth over 60 periods is not enough to judge: the bits are doubled on
    assert single.out_of_reach(_partial(chaotic, 256, 60), 256, 100_000, 8192) is None
    # within reach (2 x max_bits): doubled on
    assert single.out_of_reach(_partial(chaotic, 256, 200), 256, 400, 8192) is None
    # settling: 11 impacts in the first ~15 periods, then the non-impacting steady state below
    # x_w = 2.1; the radii stop growing (0.004 digits per period over periods 100-200):
    # 100000 periods are in reach and never refused
    settles = pi.Params.make(x_w="2.1", x0="1", v0="3")
    assert single.out_of_reach(_partial(settles, 64, 200), 64, 100_000, 8192) is None


def test_a_periodic_run_within_reach_is_certified_not_refused():
    """eta = 0.74 (period-1 orbit): no proof at 64 nor 128 bits for 1000 periods (the boxes
    grow 0.058 digits per period by the wrapping effect), the growth measured after the
    128-bit attempt (~590 proven periods) projects ~210 bits: doubled on, certified at 256
    even with max_bits = 256 (a projection within 2 x max_bits is never refused).  The Lohner
    enclosure, whose radius does not grow on the stable orbit, proves it at 64 bits."""
    r = pi.certify(
        pi.Params.make(eta="0.74"), 1000, precision="mp:64", max_bits=256, method="interval"
    )
    assert r.periods == 1000 and r.bits == 256
    assert "no proof at 128 bits" in r.bits_choice
    r = pi.certify(pi.Params.make(eta="0.74"), 1000, precision="mp:64", max_bits=256)
    assert r.method == "lohner" and r.bits == 64 and r.bits_choice == "given"
