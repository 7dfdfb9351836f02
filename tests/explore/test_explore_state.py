"""The explorer's state: a query string round-trips exactly, bad input is refused naming the
field in one line, and each view's command line and Python call give the view's own numbers."""

from __future__ import annotations

import contextlib
import io
import json

import pytest

import precise_impact as pi
from precise_impact.cli.main import main
from precise_impact.errors import ParameterError
from precise_impact.explore import api
from precise_impact.explore.state import DEFAULTS, State


def test_defaults_and_exact_round_trip():
    s = State.from_query({"eta": "89/125", "x_w": "2.5", "R": "0.8"})
    assert s.params == pi.Params.make(eta="0.712", x_w="2.5", R="0.8")  # exact: 89/125 = 0.712
    q = s.to_query()
    assert q["eta"] == "0.712" and set(DEFAULTS) <= set(q)
    assert State.from_query(q) == s


@pytest.mark.parametrize(
    "query,name",
    [
        ({"eta": "-1"}, "eta"),
        ({"R": "2"}, "R"),
        ({"bogus": "1"}, "bogus"),
        ({"model": "rk4"}, "model"),
        ({"model": "fast", "precision": "mp:256"}, "precision"),
        ({"precision": "float7"}, "precision"),
        ({"periods": "0"}, "periods"),
        ({"periods": "1e9"}, "periods"),
        ({"eta_min": "0.8", "eta_max": "0.7"}, "eta_max"),
        ({"units": "furlongs"}, "units"),
    ],
)
def test_bad_input_names_the_field_in_one_line(query, name):
    with pytest.raises(pi.ParameterError) as e:
        State.from_query(query)
    assert e.value.name == name and "\n" not in str(e.value)


def _cli_json(command: str) -> dict:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(command.split()[1:]) == 0
    d = json.loads(out.getvalue())
    d.pop("elapsed_s", None)
    return d


@pytest.mark.parametrize("view", ["orbit", "lle"])
def test_the_command_and_the_call_give_the_views_numbers(view):
    """The view's ``result`` equals the CLI's ``--json`` of its command and the ``to_dict()``
    of its Python call (every field but the wall time)."""
    s = State.from_query({"eta": "0.74", "periods": "12", "transient": "3"})
    got = getattr(api, view)(s)
    assert got["result"] == _cli_json(got["command"])
    scope: dict = {}
    exec(got["python"], scope)
    d = scope["r"].to_dict()
    d.pop("elapsed_s", None)
    assert json.loads(json.dumps(d)) == got["result"]


def test_impact_map_and_proof_calls_give_the_views_numbers():
    s = State.from_query({"eta": "0.74"})
    got = api.impact_map(s, 0.3, 1.0, 20)
    scope: dict = {}
    exec(got["python"], scope)
    assert [e.phase for e in scope["r"]] == got["phase"]
    proof = api.proof(s, 3)
    assert proof["command"] is None and proof["result"]["proven"] is True
    exec(proof["python"], scope)
    assert scope["r"].to_dict()["x"] == proof["result"]["x"]


def test_the_circuit_views_command_and_call_give_its_numbers():
    """The overlay's run is the command's (``simulate --model switched-capacitor``) and the
    Python call's, sample for sample."""
    s = State.from_query({"eta": "0.74", "periods": "6", "transient": "3"})
    got = api.circuit(s, "switched-capacitor")
    assert "--model switched-capacitor" in got["command"]
    assert got["result"] == _cli_json(got["command"])
    scope: dict = {}
    exec(got["python"], scope)
    assert [float(x) for x in scope["r"].x[3:]] == got["strobe"]["x"]


def test_a_scene_sets_the_fields_and_a_bad_one_is_refused_in_one_line(tmp_path):
    """A built-in scene and a scene file give their exact parameters and start; the rest of the
    state stays; a bad scene is the CLI's one line, naming ``scene``."""
    s = State.from_scene("fig6-period3-ideal", {"transient": "300", "eta": "0.9"})
    scene = pi.load_scene("fig6-period3-ideal")
    assert s.params == scene.params and s.periods == scene.periods and s.transient == 300
    f = tmp_path / "mine.toml"
    f.write_text(
        pi.builtin_scenes()["fig6-period3-ideal"].read_text().replace("0.74", "0.7123"),
        encoding="utf-8",
    )
    assert State.from_scene(f).to_query()["eta"] == "0.7123"
    with pytest.raises(ParameterError) as e:
        State.from_scene("no-such-scene")
    assert e.value.name == "scene" and "\n" not in str(e.value)
