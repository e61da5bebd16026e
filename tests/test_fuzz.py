"""Fuzzing the inputs a user writes: config overrides, config files and maze files.

Whatever hypothesis generates (keys, types, nesting, numbers, YAML tags, raw bytes),
loading either succeeds or raises the one error class that the commands turn into
one line; a YAML tag that would build a Python object is never executed.
"""

from __future__ import annotations

import dataclasses

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jaxnav.core.cli import one_line
from jaxnav.core.config import Config, load_config
from jaxnav.core.errors import ConfigError, MazeError
from jaxnav.world.maps import Maze, load_maze_file


def _keys() -> list[str]:
    out = []
    for f in dataclasses.fields(Config):
        if dataclasses.is_dataclass(f.type) or f.name in ("env", "dqn", "exploration", "run"):
            sub = getattr(Config(), f.name)
            out += [f"{f.name}.{g.name}" for g in dataclasses.fields(sub)]
        else:
            out.append(f.name)
    return out


KEYS = _keys()
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**12), 10**12),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
)
values = st.recursive(
    scalars,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner),
    max_leaves=8,
)
raw_values = st.one_of(
    st.sampled_from(
        [
            "1e-4",
            "5E3",
            "1_000_000",
            ".inf",
            "-.nan",
            "[1, [2, 3]]",
            "{a: 1}",
            "!!python/object/apply:os.system ['echo pwned']",
            "!!binary aGVsbG8=",
            "&a [*a]",
            "",
            "0x10",
            "'1e-4'",
        ]
    ),
    st.text(max_size=20),
)
SETTINGS = settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


@SETTINGS
@given(key=st.one_of(st.sampled_from(KEYS), st.text(max_size=15)), raw=raw_values)
def test_config_overrides_load_or_raise_config_error(key, raw):
    try:
        cfg = load_config("configs/smoke.yaml", [f"{key}={raw}"])
    except ConfigError as e:
        assert "\n" not in one_line(str(e)) and "\n" not in str(e)
    else:
        assert isinstance(cfg, Config)


@SETTINGS
@given(doc=st.dictionaries(st.sampled_from(KEYS + ["env", "dqn", "x.y"]), values, max_size=5))
def test_config_files_load_or_raise_config_error(tmp_path, doc):
    nested: dict = {}
    for k, v in doc.items():
        head, _, tail = k.partition(".")
        if tail:
            sub = nested.setdefault(head, {})
            if isinstance(sub, dict):
                sub[tail] = v
        else:
            nested[k] = v
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(nested))
    try:
        load_config(str(path))
    except ConfigError as e:
        assert "\n" not in str(e)


def _maze_or_error(path) -> None:
    try:
        m = load_maze_file(str(path))
    except MazeError as e:
        assert "\n" not in str(e)
    else:
        assert isinstance(m, Maze)


points = st.lists(
    st.lists(st.floats(-3, 3) | st.just(float("nan")) | st.integers(-5, 5), min_size=1, max_size=3),
    max_size=7,
)
maze_docs = st.fixed_dictionaries(
    {},
    optional={
        "outline": points | values,
        "obstacles": st.lists(
            st.dictionaries(st.sampled_from(["circle", "polygon", "box"]), points | values),
            max_size=3,
        )
        | values,
        "start": st.lists(st.floats(-3, 3), max_size=4) | values,
        "name": values,
    },
)


@SETTINGS
@given(doc=maze_docs)
def test_maze_documents_load_or_raise_maze_error(tmp_path, doc):
    path = tmp_path / "m.yaml"
    path.write_text(yaml.safe_dump(doc))
    _maze_or_error(path)


@SETTINGS
@given(data=st.binary(max_size=200))
def test_maze_bytes_load_or_raise_maze_error(tmp_path, data):
    path = tmp_path / "m.yaml"
    path.write_bytes(data)
    _maze_or_error(path)


def test_a_python_tag_is_refused_not_run(tmp_path):
    marker = tmp_path / "ran"
    text = f"outline: !!python/object/apply:os.system ['touch {marker}']\n"
    path = tmp_path / "m.yaml"
    path.write_text(text)
    _maze_or_error(path)
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"seed: !!python/object/apply:os.system ['touch {marker}']\n")
    try:
        load_config(str(cfg))
    except ConfigError:
        pass
    assert not marker.exists()


@SETTINGS
@given(data=st.binary(max_size=200))
def test_config_bytes_load_or_raise_config_error(tmp_path, data):
    path = tmp_path / "c.yaml"
    path.write_bytes(data)
    try:
        load_config(str(path))
    except ConfigError as e:
        assert "\n" not in str(e)
