"""The reference drivers' rows kept in the cache: read back exactly as driven, keyed by
everything they depend on, and a stale or damaged entry never trusted."""

import csv
import dataclasses
import io
import zipfile

import numpy as np
import pytest
from _tiny_run import tiny_run

from jaxnav.core.startup import reference_cache_dir
from jaxnav.experiments import refcache
from jaxnav.experiments.baselines import seats_of
from jaxnav.experiments.evaluation import evaluate, load_run
from jaxnav.experiments.rollout import padded_mazes


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return tiny_run(tmp_path_factory)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A cache folder of the test's own."""
    folder = tmp_path / "references"
    monkeypatch.setenv("JAXNAV_REFERENCE_CACHE", str(folder))
    return folder


class Driven:
    """Counts the reference tests actually driven (their planner built)."""

    def __init__(self, monkeypatch):
        self.n = 0
        built = refcache.planner_of

        def counted(*args, **kwargs):
            self.n += 1
            return built(*args, **kwargs)

        monkeypatch.setattr(refcache, "planner_of", counted)


def _reference_rows(run_dir, refs=("dwa",)) -> list[dict[str, str]]:
    """The reference drivers' rows of a small greedy test of the run."""
    _, _, text, _, _ = evaluate(run_dir, ["square4"], 1, ("greedy",), references=refs)
    return [r for r in csv.DictReader(io.StringIO(text)) if r["strategy"] in refs]


def _entries(folder):
    return sorted(folder.glob("*.npz"))


@pytest.mark.slow
def test_a_second_test_of_the_same_world_reads_the_rows_it_drove(run, cache, monkeypatch):
    _, run_dir = run
    driven = Driven(monkeypatch)
    first = _reference_rows(run_dir, ("oracle", "dwa"))
    assert driven.n == 2 and len(_entries(cache)) == 2
    assert {r["strategy"] for r in first} == {"oracle", "dwa"}
    again = _reference_rows(run_dir, ("oracle", "dwa"))
    assert driven.n == 2, "the second test drove the reference drivers again"
    assert again == first  # every field of every row, as results.csv writes it


def test_the_cache_folder_is_the_users_unless_moved_or_off(monkeypatch, tmp_path):
    monkeypatch.delenv("JAXNAV_REFERENCE_CACHE", raising=False)
    monkeypatch.delenv("JAXNAV_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert reference_cache_dir() == tmp_path / "jaxnav" / "references"
    monkeypatch.setenv("JAXNAV_REFERENCE_CACHE", str(tmp_path / "mine"))
    assert reference_cache_dir() == tmp_path / "mine"
    monkeypatch.setenv("JAXNAV_CACHE", "off")
    assert reference_cache_dir() is None
    monkeypatch.delenv("JAXNAV_CACHE")
    monkeypatch.setenv("JAXNAV_REFERENCE_CACHE", "off")
    assert reference_cache_dir() is None


@pytest.mark.slow  # 3 s on 2 cores
def test_with_the_cache_off_nothing_is_kept(run, tmp_path, monkeypatch):
    _, run_dir = run
    monkeypatch.setenv("JAXNAV_REFERENCE_CACHE", "off")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    driven = Driven(monkeypatch)
    _reference_rows(run_dir)
    _reference_rows(run_dir)
    assert driven.n == 2
    assert not any(tmp_path.rglob("*.npz"))


def test_a_stale_entry_is_driven_again_and_rewritten(run, cache, monkeypatch):
    _, run_dir = run
    first = _reference_rows(run_dir)
    (entry,) = _entries(cache)
    # the same test computed by other code (another jaxnav, JAX, NumPy, ...)
    now = refcache.stamp()
    monkeypatch.setattr(refcache, "stamp", lambda: now + " and a change")
    driven = Driven(monkeypatch)
    assert _reference_rows(run_dir) == first
    assert driven.n == 1, "an entry of other code was trusted"
    with np.load(entry) as f:
        assert str(f["meta/stamp"]) == now + " and a change"  # rewritten by this code
    assert _reference_rows(run_dir) == first and driven.n == 1


@pytest.mark.parametrize("damage", ["truncated", "garbage", "a number changed", "a field lost"])
def test_a_damaged_entry_is_driven_again_and_rewritten(run, cache, monkeypatch, damage):
    _, run_dir = run
    first = _reference_rows(run_dir)
    (entry,) = _entries(cache)
    data = entry.read_bytes()
    if damage == "truncated":
        entry.write_bytes(data[: len(data) // 2])
    elif damage == "garbage":
        entry.write_bytes(b"not an entry")
    else:
        with np.load(entry) as f:
            arrays = {k: f[k] for k in f.files}
        if damage == "a number changed":
            (k,) = [k for k in arrays if k.endswith("/goals")]
            arrays[k] = arrays[k] + 1  # the checksum no longer matches
        else:
            del arrays[next(k for k in arrays if k.endswith("/length"))]
        np.savez(entry, **arrays)
    driven = Driven(monkeypatch)
    assert _reference_rows(run_dir) == first
    assert driven.n == 1, f"a {damage} entry was trusted"
    assert zipfile.is_zipfile(entry) and entry.read_bytes() == data  # rewritten whole
    assert _reference_rows(run_dir) == first and driven.n == 1


def test_the_key_covers_the_world_the_settings_the_keys_and_the_driver(run):
    """identity() changes with each thing the rows depend on, and with nothing else."""
    _, run_dir = run
    policies = load_run(run_dir).policies
    mazes = padded_mazes(["square4", "square2"])

    def key(name="oracle", pol=policies, ms=mazes, n=3):
        return refcache.identity(name, seats_of(name, pol), ms, n)

    base = key()
    assert key() == base  # the same test: the same key
    params = policies.env_params
    env = policies.env
    changed = {
        "the driver": key("dwa"),
        "the episodes": key(n=4),
        "a test maze": key(ms=padded_mazes(["square4", "square8"])),
        "the mazes' order": key(ms=mazes[::-1]),
        "a wall moved": key(ms=[mazes[0], _moved(mazes[1])]),
        "an env parameter": key(pol=policies._replace(env_params=params.replace(R_plus=999.0))),
        "the step limit": key(pol=policies._replace(env_params=params.replace(max_steps=61))),
        "a static env setting": key(pol=policies._replace(env=_with(env, goal_candidates=7))),
        "the seeds": key(pol=_seeds(policies, 1)),
    }
    for what, k in changed.items():
        assert k != base, f"the key does not change with {what}"


def _with(env, **kw):
    return dataclasses.replace(env, **kw)


def _moved(maze):
    segments = np.asarray(maze.segments).copy()
    segments[0, 0] += 0.01
    return dataclasses.replace(maze, segments=segments)


def _seeds(policies, shift):
    labels = [(arm, seed + shift) for arm, seed in policies.labels]
    fields = [(*f[:-1], f[-1] + shift) for f in policies.fields]
    return policies._replace(labels=labels, fields=fields)


def test_the_code_stamp_is_every_source_file_and_the_libraries():
    s = refcache.stamp()
    assert s.startswith(f"{refcache.FORMAT}|") and "jax 0." in s and "numpy" in s


def test_a_cache_that_cannot_be_written_leaves_the_rows_right(run, tmp_path, monkeypatch, capsys):
    _, run_dir = run
    blocked = tmp_path / "a file"
    blocked.write_text("in the way")
    monkeypatch.setenv("JAXNAV_REFERENCE_CACHE", str(blocked / "references"))
    rows = _reference_rows(run_dir)
    assert rows and "cache was not written" in capsys.readouterr().err


def test_unkeyable_settings_are_refused_not_keyed_silently():
    with pytest.raises(TypeError, match="cannot be keyed"):
        refcache._feed(refcache.hashlib.sha256(), {"f": lambda: 0})
