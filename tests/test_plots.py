"""Figures of a run and the end-to-end reproduction report."""

import re
import shutil
from pathlib import Path

import pytest
from _tiny_run import REPRODUCE_TINY, tiny_run
from PIL import Image

from jaxnav import reproduce
from jaxnav.experiments.evaluation import evaluate_to_dir
from jaxnav.report import plots

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return tiny_run(tmp_path_factory)


def _check_image(path: Path, signature: bytes, min_size=(200, 200)):
    data = path.read_bytes()
    assert data.startswith(signature), path
    with Image.open(path) as im:
        assert im.size[0] >= min_size[0] and im.size[1] >= min_size[1], (path, im.size)
        colors = im.convert("RGB").getcolors(maxcolors=1 << 16)  # None: even more colours
        assert colors is None or len(colors) > 8, path  # not a blank canvas


def test_plots_of_a_tiny_run_are_written_and_non_empty(run, capsys):
    cfg, out = run
    evaluate_to_dir(out)  # the plots read its first test episodes
    assert plots.main([str(out)]) == 0
    d = out / "plots"
    printed = capsys.readouterr().out.split()
    expected = (
        ["training_curves.png", "exploration.png"]
        + [f"trajectory_{m}.png" for m in cfg.run.test_mazes]
        + ["episode.gif"]
    )
    assert sorted(p.name for p in d.iterdir()) == sorted(expected)  # and no temp files left
    assert [Path(p).name for p in printed] == expected
    for name in expected[:-1]:
        _check_image(d / name, PNG)
    gif = d / "episode.gif"
    _check_image(gif, b"GIF8")
    assert gif.stat().st_size < 1_000_000
    with Image.open(gif) as im:
        assert im.n_frames > 5


def test_a_run_not_yet_evaluated_gets_its_training_figures_and_a_hint(run, tmp_path, capsys):
    """The plots draw files; without eval/trajectories.npz they play nothing."""
    _, src = run
    d = tmp_path / "run"
    d.mkdir()
    for name in ("config.yaml", "params.npz", "metrics.csv", "explore.csv"):
        shutil.copy(src / name, d / name)
    written = plots.make_plots(d)
    assert [p.name for p in written] == ["training_curves.png", "exploration.png"]
    assert not (d / "eval").exists()
    assert f"python -m jaxnav.evaluate {d}" in capsys.readouterr().err


def test_safe_name_of_a_maze_file():
    assert plots.safe_name("configs/mazes/corridor.yaml") == "corridor"
    assert plots.safe_name("square4") == "square4"


@pytest.mark.parametrize(
    "case, message", [("missing", "does not exist"), ("no_metrics", "has no metrics.csv")]
)
def test_bad_input_is_one_line_and_exit_2(run, case, message, tmp_path, capsys):
    _, src = run
    d = tmp_path / "run"
    if case == "no_metrics":
        d.mkdir()
        shutil.copy(src / "config.yaml", d / "config.yaml")
    assert plots.main([str(d)]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and "Traceback" not in err
    assert not (d / "plots").exists()


def test_reproduce_quick_end_to_end(run, tmp_path, capsys):
    """Both experiments trained, tested and plotted; report.md holds tables and figures.

    The no-obstacle experiment is the shared tiny run (``--resume`` reuses a finished
    training); the obstacle one is trained here.
    """
    _, src = run
    out = tmp_path / "repro"
    out.mkdir()
    shutil.copytree(src, out / "paper_no_obstacles", ignore=shutil.ignore_patterns("eval", "plots"))
    assert reproduce.main([*REPRODUCE_TINY, "--out", str(out), "--resume", "--quiet"]) == 0
    report = (out / "report.md").read_text()
    for stage in ("train", "evaluate", "plot", "robustness"):
        for exp in ("paper_no_obstacles", "paper_obstacles"):
            assert re.search(rf"\| {stage} {exp} \| [0-9.]+ s", report), (stage, exp)
    assert "reused (trained before; time from its summary.json" in report
    assert (out / "paper_obstacles" / "params.npz").is_file()
    assert "| CPU |" in report and "| JAX | 0." in report and "backend cpu" in report
    assert "2 seeds per strategy, 4 training episodes of at most 60 steps" in report
    # the paper's numbers beside ours, both tables
    assert "| square4 | 4x4 Square | 3731.92 ± 368.35 |" in report
    assert "| square4_obstacles | 4x4 Square | 1125.45 ± 775.82 |" in report
    assert "| pentagon_obstacles | Pentagon | 890.99 ± 641.19 |" in report
    # every figure link resolves
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", report)
    # curves, exploration, GIF, robustness per run; one path per test maze
    assert len(links) == 2 * 4 + 5 + 2
    for link in links:
        assert (out / link).is_file(), link
    # the report's tables are the evaluation's
    tables = (out / "paper_obstacles" / "eval" / "tables.md").read_text()
    assert tables.split("\n### Across seeds")[1].split("\n### ")[0].strip() in report
    assert "## Test mode: exploring" in tables
    # the claims table, computed from the files, at the top; a quick run says so
    claims = (out / "claims.md").read_text()
    assert claims.split("\n", 1)[1].strip() in report
    assert "## The paper's claims, judged" in report and "not conclusive" in report
    assert "| Fig. 2(b) | EBE learns faster (no obstacles) | training |" in report
    # without --resume a finished reproduction is not overwritten
    before = (out / "report.md").read_bytes()
    assert reproduce.main([*REPRODUCE_TINY, "--out", str(out), "--quiet"]) == 2
    assert "already exists" in capsys.readouterr().err
    assert (out / "report.md").read_bytes() == before


def test_reproduce_refuses_a_run_trained_with_other_settings(run, tmp_path, capsys):
    _, src = run
    out = tmp_path / "repro"
    out.mkdir()
    shutil.copytree(src, out / "paper_no_obstacles")
    argv = [*REPRODUCE_TINY, "--episodes", "5", "--out", str(out), "--resume", "--quiet"]
    assert reproduce.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "other settings" in err and "\n" not in err
    assert not (out / "paper_obstacles").exists() and not (out / "report.md").exists()
