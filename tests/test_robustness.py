"""Evaluation under sensor perturbations (evaluate --robustness)."""

import csv
import io
import re

import numpy as np
import pytest
from _tiny_run import tiny_run

from jaxnav.commands.evaluate import main
from jaxnav.core.errors import JaxnavError
from jaxnav.experiments.evaluation import evaluate_to_dir, load_run
from jaxnav.experiments.robustness import perturb, realism_settings, robustness_to_dir
from jaxnav.report.results import UNPERTURBED, robustness_summary
from jaxnav.report.tables import robustness_markdown

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


@pytest.mark.slow
def test_robustness_files_are_written(swept):
    _, out = swept
    for name in ("robustness.csv", "robustness.md", "robustness.png"):
        assert (out / "rob" / name).stat().st_size > 0, name
    assert (out / "rob" / "robustness.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert {r["perturbation"] for r in _rows(out / "rob" / "robustness.csv")} == set(SWEEP)


@pytest.mark.slow
def test_unperturbed_rows_equal_the_plain_evaluation_and_perturbed_rows_differ(swept):
    _, out = swept
    rob = _rows(out / "rob" / "robustness.csv")
    plain = [r for r in _rows(out / "plain" / "results.csv") if r["mode"] == "greedy"]
    plain = [r for r in plain if r["strategy"] not in ("oracle", "dwa")]  # the policies
    key = lambda r: (r["strategy"], r["seed"], r["maze"], r["episode"])  # noqa: E731
    none = {key(r): r["return"] for r in rob if r["perturbation"] == UNPERTURBED}
    assert none == {key(r): r["return"] for r in plain}
    noisy = {key(r): r["return"] for r in rob if r["perturbation"] == "noisy"}
    assert noisy != none


@pytest.mark.slow
def test_robustness_table_is_recomputed_from_the_csv(swept):
    _, out = swept
    text = (out / "rob" / "robustness.csv").read_text()
    rows = robustness_summary(text)
    data = list(csv.DictReader(io.StringIO(text)))
    for r in rows:
        per_seed = {}
        for d in data:
            if (d["perturbation"], d["maze"], d["strategy"]) == (
                r.perturbation,
                r.maze,
                r.strategy,
            ):
                per_seed.setdefault(d["seed"], []).append(float(d["return"]))
        assert r.mean.value == pytest.approx(
            np.mean([np.mean(v) for v in per_seed.values()]), rel=1e-6
        )


@pytest.mark.slow
def test_robustness_markdown_is_a_function_of_the_csv(swept, tmp_path_factory):
    """robustness.md is robustness_markdown(robustness.csv); its cells match the CSV."""
    cfg, out = swept
    _, run_dir = tiny_run(tmp_path_factory)
    run = load_run(run_dir)
    text = (out / "rob" / "robustness.csv").read_text()
    md = (out / "rob" / "robustness.md").read_text()
    assert md == robustness_markdown(
        text,
        cfg.env.maze,
        realism_settings(run.policies.env, run.policies.env_params),
        SWEEP,
        title=f"Robustness of {run_dir.name} to sensor noise",
        figure="robustness.png",
    )
    data = list(csv.DictReader(io.StringIO(text)))
    lines = md.splitlines()
    names = {"ebe": "EBE", "epsilon_greedy": "epsilon-greedy"}

    def per_seed(p, s):
        by = {}
        for d in data:
            if (d["perturbation"], d["strategy"]) == (p, s):
                by.setdefault(int(d["seed"]), []).append(float(d["return"]))
        return np.asarray([np.mean(by[k]) for k in sorted(by)])

    for p in SWEEP:
        for s in cfg.strategies:
            row = next(x for x in lines if x.startswith(f"| {p} | ") and f"| {names[s]} |" in x)
            cells = [c.strip() for c in row.strip("|").split("|")]
            x, ref = per_seed(p, s), per_seed(UNPERTURBED, s)
            mine = [d for d in data if (d["perturbation"], d["strategy"]) == (p, s)]
            assert cells[3].startswith(f"{x.mean():.1f} [")
            if p == UNPERTURBED:
                assert cells[4:6] == ["", ""]
            else:  # paired by seed
                assert cells[4].startswith(f"{(x - ref).mean():+.1f} [")
                assert cells[5] == f"{100 * (x - ref).mean() / abs(ref.mean()):+.0f}%"
            assert cells[6:] == [
                f"{np.mean([float(d['goals']) for d in mine]):.2f}",
                f"{np.mean([float(d['collided']) for d in mine]):.2f}",
            ]


def test_a_perturbation_must_keep_the_observation(tmp_path_factory):
    _, run_dir = tiny_run(tmp_path_factory)
    run = load_run(run_dir)
    env, params = perturb(
        run.policies.env, run.policies.env_params, {"beam_dropout": 0.2, "lidar_noise_std": 0.05}
    )
    assert (env.beam_dropout, params.lidar_noise_std) == (0.2, 0.05)
    assert run.policies.env.beam_dropout == 0.0  # the training env is left as it was
    for bad, message in (
        ({"n_beams": 12}, "observation size"),
        ({"wind": 1.0}, "unknown environment setting 'wind'"),
        ({"beam_dropout": 1.5}, "beam_dropout must be in [0, 1)"),
    ):
        with pytest.raises(JaxnavError, match=re.escape(message)):
            perturb(run.policies.env, run.policies.env_params, bad)


@pytest.mark.parametrize(
    "extra, message",
    [(["--episodes", "0"], "at least 1"), (["--mazes", "nowhere"], "unknown maze 'nowhere'")],
)
def test_bad_robustness_input_is_one_line_and_exit_2(
    tmp_path_factory, tmp_path, capsys, extra, message
):
    _, run_dir = tiny_run(tmp_path_factory)
    assert main([str(run_dir), "--robustness", "--out", str(tmp_path / "e"), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "e").exists()  # nothing half-written
