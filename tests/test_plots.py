"""Figures of a run and the end-to-end reproduction report."""

import csv
import inspect
import io
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from _tiny_run import REPRODUCE_TINY, tiny_run
from matplotlib.colors import to_hex, to_rgb
from matplotlib.figure import Figure
from PIL import Image

from jaxnav.commands import plots as plots_command
from jaxnav.commands import reproduce
from jaxnav.core import strategies as registry
from jaxnav.core.config import load_config
from jaxnav.core.sweep import row_arm
from jaxnav.experiments.evaluation import evaluate_to_dir
from jaxnav.experiments.rollout import run_tests
from jaxnav.report import plots
from jaxnav.report.results import ROBUSTNESS_COLUMNS, display_name, read_episodes_npz
from jaxnav.world.maps import make_maze

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


@pytest.mark.slow
def test_plots_of_a_tiny_run_are_written_and_non_empty(run, capsys):
    cfg, out = run
    evaluate_to_dir(out)  # the plots read its first test episodes
    assert plots_command.main([str(out)]) == 0
    d = out / "plots"
    printed = capsys.readouterr().out.split()
    expected = (
        ["training_curves.png", "exploration.png"]
        + [f"failures_{m}.png" for m in cfg.run.test_mazes]  # where failed attempts ended
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
    err = capsys.readouterr().err
    assert f"jaxnav evaluate {d}" in err and "was not tested yet" in err
    cfg = load_config(str(d / "config.yaml"))
    assert all(m in err for m in cfg.run.test_mazes), err  # it names the mazes it would test


def test_safe_name_of_a_maze_file():
    assert plots.safe_name("configs/mazes/corridor.yaml") == "corridor"
    assert plots.safe_name("square4") == "square4"


@pytest.fixture
def drawn(monkeypatch):
    """The figures saved while a test runs, each once, in order."""
    figures = []
    savefig = Figure.savefig

    def recording(fig, *args, **kwargs):
        if not any(f is fig for f in figures):
            figures.append(fig)
        return savefig(fig, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", recording)
    return figures


def _titles(fig) -> str:
    return " | ".join([fig.get_suptitle(), *(ax.get_title() for ax in fig.axes)])


# Four EBE temperatures, epsilon-greedy, Boltzmann: six arms, as a swept run names them.
SIX_ARMS = [("ebe", "0.1"), ("ebe", "0.3"), ("ebe", "1"), ("ebe", "3")]
SIX_ARMS += [("epsilon_greedy", ""), ("boltzmann", "")]


def _write_csv(path: Path, header: list[str], rows: list[list]) -> None:
    with open(path, "w", newline="") as f:
        csv.writer(f).writerows([header, *rows])


def _swept_run(d: Path, arms) -> Path:
    """metrics.csv and explore.csv of a swept run of ``arms``: 2 seeds, 30 episodes."""
    d.mkdir()
    rng = np.random.default_rng(0)
    lead = ["strategy", "exploration.ebe_temperature", "seed"]
    metrics, explore = [], []
    for strategy, temperature in arms:
        for seed in (0, 1):
            for e in range(30):
                metrics.append([strategy, temperature, seed, e, rng.normal(50.0 * e, 100.0)])
                explore.append([strategy, temperature, seed, 100 * e, rng.uniform()])
    _write_csv(d / "metrics.csv", [*lead, "episode", "return"], metrics)
    _write_csv(d / "explore.csv", [*lead, "step", "explore"], explore)
    return d


def _arm_name(strategy: str, temperature: str) -> str:
    return display_name(f"{strategy} ebe_temperature={temperature}" if temperature else strategy)


def _is_grey(color) -> bool:
    r, g, b = to_rgb(color)
    return r == g == b


@pytest.mark.parametrize("figure", ["training_curves", "exploration"])
def test_six_arms_get_a_panel_each_in_their_own_colour_and_line_style(tmp_path, drawn, figure):
    """Six bands in one panel overlap into one: each arm gets its own panel, titled with
    its name, its band drawn in colour over the other arms' means in grey."""
    d = _swept_run(tmp_path / "run", SIX_ARMS)
    getattr(plots, f"plot_{figure}")(d, tmp_path / "figure.png")
    (fig,) = drawn
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 6
    styles = []
    for ax, arm in zip(axes, SIX_ARMS):
        assert ax.get_title().startswith(f"{_arm_name(*arm)} ("), ax.get_title()
        lines = ax.get_lines()
        coloured = [line for line in lines if not _is_grey(line.get_color())]
        assert len(coloured) == 1 and len(lines) == 6  # the arm's mean, the others' five
        styles.append((to_hex(coloured[0].get_color()), coloured[0].get_linestyle()))
    assert len(set(styles)) == 6
    # EBE's four temperatures: shades of one colour, so each its own line style as well
    assert len({linestyle for _, linestyle in styles[:4]}) == 4


def test_three_arms_share_one_panel_with_a_legend(tmp_path, drawn):
    arms = [("ebe", ""), ("epsilon_greedy", ""), ("boltzmann", "")]
    plots.plot_training_curves(_swept_run(tmp_path / "run", arms), tmp_path / "curves.png")
    (fig,) = drawn
    (ax,) = fig.axes
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == [f"{_arm_name(*a)} (2 seeds)" for a in arms]


@pytest.fixture
def toy_strategy():
    """A strategy registered beyond the built-in three, removed afterwards."""
    registry.register("straight", "jaxnav.agent.exploration:act_ebe", label="Straight")
    yield "straight"
    registry.unregister("straight")


@pytest.mark.parametrize("figure", ["training_curves", "exploration"])
def test_a_registered_strategy_gets_its_own_colour(tmp_path, drawn, toy_strategy, figure):
    arms = [("ebe", ""), ("epsilon_greedy", ""), ("boltzmann", ""), (toy_strategy, "")]
    getattr(plots, f"plot_{figure}")(_swept_run(tmp_path / "run", arms), tmp_path / "f.png")
    (fig,) = drawn
    assert fig.axes[-1].get_title().startswith("Straight (")
    colours = {to_hex(ax.title.get_color()) for ax in fig.axes}
    assert len(colours) == 4 and not any(_is_grey(c) for c in colours)


MODE_IN_TITLE = re.compile(r"test mode: (greedy|exploring)\b")


@pytest.mark.slow
def test_trajectory_and_episode_titles_name_the_test_mode_of_their_episodes(run, tmp_path, drawn):
    """The recorded episodes are one test mode's (results.csv tells which: the first
    episode of the config's seed); every figure drawn from them names that mode."""
    cfg, src = run
    if not (src / "eval" / "trajectories.npz").is_file():
        evaluate_to_dir(src)
    rows = list(csv.DictReader(io.StringIO((src / "eval" / "results.csv").read_text())))
    episodes, _ = read_episodes_npz(src / "eval" / "trajectories.npz")
    modes = {row["mode"] for row in rows}
    for maze, per_arm in episodes.items():
        for arm, ep in per_arm.items():
            first = {
                r["mode"]: float(r["return"])
                for r in rows
                if (r["maze"], row_arm(r), int(r["seed"]), r["episode"])
                == (maze, arm, cfg.seed, "0")
            }
            same = pytest.approx(float(ep["return"]), abs=1e-3)  # results.csv: 4 decimals
            modes &= {m for m, v in first.items() if v == same}
    assert modes, "the recorded episodes are no test mode's first episodes"
    written = plots.plot_test_episodes(src, tmp_path)
    assert len(written) == len(cfg.run.test_mazes) + 1 and len(drawn) == len(written)
    for fig in drawn:  # the trajectories, then the GIF's figure (titled at its last frame)
        named = MODE_IN_TITLE.findall(_titles(fig))
        assert named and set(named) <= modes, _titles(fig)


def _episode(n: int = 20) -> dict:
    t = np.linspace(-1.0, 1.0, n)
    return {
        "pos": np.stack([t, 0.5 * t], axis=1),
        "goal": np.tile([1.0, -1.0], (n, 1)),
        "reached": np.zeros(n, bool),
        "collided": False,
        "return": 12.0,
        "goals": 0,
    }


@pytest.mark.parametrize("mode", ["greedy", "exploring"])
def test_a_trajectory_title_names_the_mode_it_is_given(tmp_path, drawn, mode):
    episodes = {"ebe": _episode(), "epsilon_greedy": _episode()}
    maze = make_maze("square4")
    plots.plot_trajectory(maze, "square4", episodes, 0, 0.2, tmp_path / "t.png", mode=mode)
    (fig,) = drawn
    assert MODE_IN_TITLE.findall(_titles(fig)) == [mode]


def _robustness_csv() -> str:
    rows = [list(ROBUSTNESS_COLUMNS)]
    for strategy in ("ebe", "epsilon_greedy"):
        for seed in (0, 1):
            for perturbation in ("none", "range_noise_0.05"):
                rows += [
                    [strategy, seed, perturbation, "square4", e, 100 + 10 * seed + e, 1, 0, 200]
                    for e in range(2)
                ]
    out = io.StringIO()
    csv.writer(out, lineterminator="\n").writerows(rows)
    return out.getvalue()


@pytest.mark.parametrize("mode", [None, "greedy", "exploring"])
def test_the_robustness_title_names_the_test_mode(tmp_path, drawn, mode):
    """robustness.csv has no mode column: its episodes are the plain test's, played in
    run_tests' default mode (greedy), which the figure names unless told otherwise."""
    kw = {} if mode is None else {"mode": mode}
    plots.plot_robustness(_robustness_csv(), tmp_path / "r.png", title="tiny", **kw)
    (fig,) = drawn
    assert MODE_IN_TITLE.findall(_titles(fig)) == [mode or "greedy"], _titles(fig)
    assert inspect.signature(run_tests).parameters["mode"].default == "greedy"


@pytest.mark.parametrize(
    "case, message", [("missing", "does not exist"), ("no_metrics", "has no metrics.csv")]
)
def test_bad_input_is_one_line_and_exit_2(run, case, message, tmp_path, capsys):
    _, src = run
    d = tmp_path / "run"
    if case == "no_metrics":
        d.mkdir()
        shutil.copy(src / "config.yaml", d / "config.yaml")
    assert plots_command.main([str(d)]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and "Traceback" not in err
    assert not (d / "plots").exists()


@pytest.mark.slow
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
    # the claims compare the strategies: no reference driver drives unless asked
    results = out / "paper_obstacles" / "eval" / "results.csv"
    assert "\noracle," not in results.read_text() and "\ndwa," not in results.read_text()
    # without --resume a finished reproduction is not overwritten
    before = (out / "report.md").read_bytes()
    assert reproduce.main([*REPRODUCE_TINY, "--out", str(out), "--quiet"]) == 2
    assert "already exists" in capsys.readouterr().err
    assert (out / "report.md").read_bytes() == before
    # --baselines tests the oracle and DWA beside the policies (the trainings reused)
    argv = [*REPRODUCE_TINY, "--out", str(out), "--resume", "--baselines", "--quiet"]
    assert reproduce.main(argv) == 0
    assert "\noracle," in results.read_text() and "\ndwa," in results.read_text()
    assert "the oracle and DWA beside them" in (out / "report.md").read_text()


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
