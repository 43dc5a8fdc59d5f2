"""A fuzz of the problem-file loader: valid files mutated (values replaced by anything JSON
holds, NaN and Infinity nested in lists and objects included; keys dropped or added; the
text cut or spliced) load as a TestSet or raise ProblemFileError with one line, and
nothing else (a probe found 118 of 4,000 such files ending in a TypeError)."""

from __future__ import annotations

import copy
import json
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mpnet.envs.spec import TestSet as TSet  # not "Test*": pytest would try to collect it
from mpnet.envs.specs import get_spec
from mpnet.problems import FORMAT, FORMAT_2, ProblemFileError, load_problems

KEYS = ["format", "env", "workspaces", "id", "obstacles", "queries", "center", "size", "start", "goal"]
KEYS += ["reference_cost", "type", "orientation"]


def _base(env: str) -> dict:
    """A valid file for env, with every key the loader reads (an @2 one for the arm)."""
    spec = get_spec(env)
    w, s = spec.workspace_dim, spec.state_dim
    obstacles = [{"center": [0.0] * w, "size": [1.0] * w}, {"center": [2.0] * w, "size": [0.5] * w}]
    queries = [{"start": [-1.0] * s, "goal": [1.0] * s, "reference_cost": 5.0}, {"start": [0.5] * s, "goal": [0.0] * s}]
    if env == "arm7":
        obstacles.append({"type": "cylinder", "center": [0.5, 0.0, 0.2], "size": [0.1, 0.1, 0.4]})
        obstacles.append({"type": "box", "center": [0.5] * 3, "size": [0.2] * 3, "orientation": [0, 0, 0, 1]})
        queries[1]["id"] = "scene/0001"
    return {
        "format": FORMAT_2 if env == "arm7" else FORMAT,
        "env": env,
        "note": {"why": "an ignored key"},
        "workspaces": [
            {"id": "a", "obstacles": obstacles, "queries": queries},
            {"id": "b", "obstacles": [], "queries": []},
        ],
    }


NON_FINITE = st.sampled_from([math.nan, math.inf, -math.inf])
LEAVES = (
    st.none()
    | st.booleans()
    | st.integers(-(10**400), 10**400)
    | st.floats(allow_nan=True, allow_infinity=True)
    | NON_FINITE
    | st.text(max_size=8)
    | st.sampled_from(["s2d", "arm7", FORMAT, FORMAT_2, "box", "sphere", "cylinder", ""])
)
VALUES = st.recursive(
    LEAVES,
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.sampled_from(KEYS) | st.text(max_size=4), inner, max_size=4)
    ),
    max_leaves=10,
)


def _paths(v, at=()):
    """Every place in a document: (path, value)."""
    yield at, v
    items = v.items() if isinstance(v, dict) else enumerate(v) if isinstance(v, list) else ()
    for k, x in items:
        yield from _paths(x, (*at, k))


@st.composite
def _mutated(draw):
    env = draw(st.sampled_from(["s2d", "c3d", "rigid", "arm7"]))
    doc = copy.deepcopy(_base(env))
    for _ in range(draw(st.integers(1, 3))):
        at, value = draw(st.sampled_from(list(_paths(doc))))
        if not at:
            doc = draw(VALUES)
            continue
        parent = doc
        for k in at[:-1]:
            parent = parent[k]
        action = draw(st.sampled_from(["replace", "drop", "add"]))
        if action == "drop" and isinstance(parent, dict):
            del parent[at[-1]]
        elif action == "add" and isinstance(value, dict):
            value[draw(st.sampled_from(KEYS))] = draw(VALUES)
        elif action == "add" and isinstance(value, list):
            value.append(draw(VALUES))
        else:
            parent[at[-1]] = draw(VALUES)
    return env, json.dumps(doc)  # NaN and Infinity as JavaScript's literals, which the loader refuses


@st.composite
def _spliced(draw):
    """The text of a valid file cut, or with a token spliced in (non-finite literals, huge
    numbers, brackets, escapes)."""
    env = draw(st.sampled_from(["s2d", "arm7"]))
    text = json.dumps(_base(env))
    i = draw(st.integers(0, len(text)))
    j = draw(st.integers(i, min(len(text), i + 8)))
    token = draw(
        st.sampled_from(["NaN", "Infinity", "-Infinity", "1e999", "-1e400", "9" * 5000, "[", "]", "{", "}", ",", ":"])
        | st.sampled_from(['"', "\\u0000", "\\ud800", "null", "true", "[NaN]", '{"x": [Infinity]}', "[" * 3000])
        | st.text(max_size=4)
    )
    return env, text[:i] + token + text[j:]


def _load(tmp_path_factory, env: str, text: str):
    path = tmp_path_factory.getbasetemp() / "fuzz.json"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    try:
        return load_problems(path, get_spec(env))
    except ProblemFileError as e:
        assert "\n" not in str(e) and str(e).startswith(f"{path}: "), str(e)
        return e


COUNTS: dict[str, int] = {}


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_mutated())
@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_mutated_problem_files_load_or_raise_one_line(tmp_path_factory, case):
    got = _load(tmp_path_factory, *case)
    assert isinstance(got, (TSet, ProblemFileError))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_spliced())
def test_spliced_problem_files_load_or_raise_one_line(tmp_path_factory, case):
    got = _load(tmp_path_factory, *case)
    assert isinstance(got, (TSet, ProblemFileError))


@pytest.mark.parametrize(
    "where",
    [
        lambda d: d.__setitem__("format", [math.nan]),
        lambda d: d["workspaces"][0].__setitem__("id", {"x": [math.inf]}),
        lambda d: d["workspaces"][0]["obstacles"][0].__setitem__("center", {"x": -math.inf}),
        lambda d: d["workspaces"][0]["queries"][0].__setitem__("start", [[math.nan], 1.0]),
        lambda d: d["workspaces"][0]["queries"][0].__setitem__("reference_cost", [math.inf]),
        lambda d: d.__setitem__("env", [math.nan]),
    ],
)
def test_nested_non_finite_is_named_not_a_type_error(tmp_path_factory, where):
    """The probe's failures: a NaN or Infinity inside a list or object where the loader
    quotes the value in its message (`TypeError: Object of type _NonFinite ...`)."""
    doc = _base("s2d")
    where(doc)
    got = _load(tmp_path_factory, "s2d", json.dumps(doc))
    assert isinstance(got, ProblemFileError)
