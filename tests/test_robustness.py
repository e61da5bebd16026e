"""Evaluation under sensor perturbations (evaluate --robustness)."""

import csv
import io

import numpy as np
import pytest

from _tiny_run import tiny_run
from jaxnav.evaluate import (
    UNPERTURBED,
    evaluate_to_dir,
    robustness_summary,
    robustness_to_dir,
)

SWEEP = {UNPERTURBED: {}, "noisy": {"lidar_noise_std": 0.1}, "dropout": {"beam_dropout": 0.3}}


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    cfg, run_dir = tiny_run(tmp_path_factory)
    out = tmp_path_factory.mktemp("rob")
    robustness_to_dir(run_dir, ["square4"], 2, out / "rob", perturbations=SWEEP)
    evaluate_to_dir(run_dir, ["square4"], 2, out / "plain")
    return cfg, out


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def test_robustness_files_are_written(swept):
    _, out = swept
    for name in ("robustness.csv", "robustness.md", "robustness.png"):
        assert (out / "rob" / name).stat().st_size > 0, name
    assert (out / "rob" / "robustness.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert {r["perturbation"] for r in _rows(out / "rob" / "robustness.csv")} == set(SWEEP)


def test_unperturbed_rows_equal_the_plain_evaluation_and_perturbed_rows_differ(swept):
    _, out = swept
    rob = _rows(out / "rob" / "robustness.csv")
    plain = _rows(out / "plain" / "results.csv")
    key = lambda r: (r["strategy"], r["seed"], r["maze"], r["episode"])  # noqa: E731
    none = {key(r): r["return"] for r in rob if r["perturbation"] == UNPERTURBED}
    assert none == {key(r): r["return"] for r in plain}
    noisy = {key(r): r["return"] for r in rob if r["perturbation"] == "noisy"}
    assert noisy != none


def test_robustness_table_is_recomputed_from_the_csv(swept):
    _, out = swept
    text = (out / "rob" / "robustness.csv").read_text()
    rows = robustness_summary(text)
    data = list(csv.DictReader(io.StringIO(text)))
    for r in rows:
        per_seed = {}
        for d in data:
            if (d["perturbation"], d["maze"], d["strategy"]) == (r.perturbation, r.maze, r.strategy):
                per_seed.setdefault(d["seed"], []).append(float(d["return"]))
        assert r.mean.value == pytest.approx(np.mean([np.mean(v) for v in per_seed.values()]), rel=1e-6)
