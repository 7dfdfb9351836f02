"""The one deprecation path for renamed keywords."""

import warnings

import pytest

from precise_impact.core.compat import UNSET, renamed
from precise_impact.errors import ParameterError


def _f(precision=UNSET, bits=UNSET):
    return renamed(
        precision,
        bits,
        old="bits",
        new="precision",
        where="f",
        convert=lambda b: f"mp:{b}",
        default="auto",
    )


def test_new_spelling_is_silent_and_default_applies():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _f() == "auto" and _f("mp:256") == "mp:256"


def test_old_spelling_warns_at_the_callers_line_and_converts():
    with pytest.warns(DeprecationWarning, match=r"f: bits= is deprecated, use precision=") as w:
        assert _f(bits=448) == "mp:448"
    assert w[0].filename == __file__  # the warning points at the caller of f, not at f


def test_both_spellings_are_refused():
    with pytest.raises(ParameterError, match="not both"):
        _f("mp:256", 448)


def test_renamed_attribute_reads_and_writes_the_new_one_with_a_warning():
    import dataclasses

    from precise_impact.core.compat import RenamedAttribute

    @dataclasses.dataclass
    class R:
        n_impacts: int
        impacts = RenamedAttribute("n_impacts")

    r = R(3)
    assert [f.name for f in dataclasses.fields(R)] == ["n_impacts"]  # not a field
    with pytest.warns(DeprecationWarning, match=r"R: impacts is deprecated, use n_impacts"):
        assert r.impacts == 3
    with pytest.warns(DeprecationWarning):
        r.impacts = 5
    assert r.n_impacts == 5
