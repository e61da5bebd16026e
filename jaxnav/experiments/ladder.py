"""A ladder study: the same arms trained on worlds of growing difficulty, tested on the
world they trained on and on worlds they never saw.

A study file (``configs/studies/when_ebe_helps.yaml``) names its rungs (a shipped config
and settings over it), its agents (settings), its strategies and its budget. Every
(rung, agent) pair is one cell: one training run with every strategy x seed in one
compiled program (``DIR/cells/RUNG.AGENT/``, a run directory like ``jaxnav train``'s),
then a greedy test of every policy on

* the rung's own world: its maze, or for a drawn family its train layouts (``FAMILY:train``);
* a drawn family's test layouts (``FAMILY:test``), which training never drew;
* a larger size of the family (``larger``), drawn from its test split;
* the study's fixed generalisation mazes (``generalise_to``, e.g. ROBOTIS stage 4).

A cell is done when its ``seeds.csv`` (per-seed scores of every test) is written, so an
interrupted study resumes where it stopped: finished cells are reused, an unfinished
training resumes from its last checkpoint. The study then writes its data
(:data:`DATA_FILES`) into ``DIR/data/``; :mod:`jaxnav.report.ladder` turns the data
into the page and its figures.
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from jaxnav.core import agents, baselines
from jaxnav.core.config import Config, config_to_dict
from jaxnav.core.errors import ConfigError, JaxnavError
from jaxnav.core.rundir import EVAL, METRICS, CsvLog, atomic_write_text, csv_text
from jaxnav.core.settings import SEED, problem
from jaxnav.core.shipped import CONFIG_DIR
from jaxnav.core.values import flatten
from jaxnav.experiments import runner, studyfile
from jaxnav.experiments.evaluation import drawn_name
from jaxnav.report import stats, study_pages
from jaxnav.report.ladder import (
    DATA_FILES,
    LEARNING_FILES,
    Data,
    trajectory_cell,
)
from jaxnav.report.navigation import seed_metrics
from jaxnav.report.results import read_results
from jaxnav.world.maps import make_maze

STUDY_KEYS = {
    "kind": str,  # "ladder", or left out: a file with rungs is one
    "title": str,
    "seed": int,
    "seeds": int,
    "total_steps": int,
    "test_episodes": int,
    "strategies": list,
    "settings": dict,
    "agents": dict,
    "rungs": dict,
    "generalise_to": list,
    "eval_points": int,  # greedy evaluations along each cell's budget (0: none)
    # for the page only: lines under its setup, what the study leaves out, an earlier page
    "notes": list,
    "left_out": list,
    "previous": str,
    "cost": str,  # what a whole run of it took, measured (jaxnav list studies)
}
REQUIRED = ("title", "seeds", "total_steps", "strategies", "agents", "rungs")
AGENT_KEYS = {"label": str, "settings": dict, "rungs": list}
RUNG_KEYS = {"label": str, "config": str, "settings": dict, "larger": dict, "total_steps": int}
CURVE_POINTS = 41  # learning-curve points per cell, over the share of the step budget
CURVE_WINDOW = 20  # episodes in a curve's moving mean
SCORE_COLUMNS = (
    "rung",
    "agent",
    "strategy",
    "seed",
    "test",
    "episodes",
    "attempts",
    "return",
    "success",
    "spl",
    "collision",
    "cut",  # attempts cut by an episode's end, per episode (left out of the rates)
    "goals_per_min",
)
# One row per seed and greedy evaluation while it trains (eval_points): the learning curve
# the study's measures of learning speed come from (jaxnav.report.learning).
EVAL_COLUMNS = ("rung", "agent", "strategy", "seed", "env_step", "wall_s", "success", "collision")
# ... and, where the cell recorded what its runs explored (run.coverage), the env steps by
# each seed's first goal in training (empty before one) and the share of the world's free
# cells it had visited (jaxnav.report.exploring reads them)
EXPLORED_COLUMNS = ("first_goal", "coverage")


@dataclass(frozen=True)
class Rung:
    name: str
    label: str
    config: str  # a shipped config's name
    settings: dict[str, Any]
    larger: dict[str, Any]  # settings over the cell's config for the larger size ({} none)
    total_steps: int | None = None  # the world's own budget per seed (None: the study's)


@dataclass(frozen=True)
class Agent:
    name: str
    label: str
    settings: dict[str, Any]
    rungs: tuple[str, ...] | None = None  # the rungs it trains on (None: every rung)


@dataclass(frozen=True)
class Study:
    title: str
    seed: int
    seeds: int
    total_steps: int
    test_episodes: int
    strategies: tuple[str, ...]
    settings: dict[str, Any]
    agents: tuple[Agent, ...]
    rungs: tuple[Rung, ...]
    generalise_to: tuple[str, ...]
    text: str  # the study file, as read
    eval_points: int = 0  # greedy evaluations along each cell's budget

    def cells(self) -> list[tuple[Rung, Agent]]:
        return [
            (r, a) for r in self.rungs for a in self.agents if a.rungs is None or r.name in a.rungs
        ]


def parse_study(text: str, where: str) -> Study:
    """A study from its YAML text; every cell's config is built, so a wrong setting
    anywhere is one line here, before any training."""
    doc = studyfile.mapping(text, where)
    studyfile.typed(doc, STUDY_KEYS, where)
    studyfile.required(doc, REQUIRED, where)
    studyfile.at_least_one(doc, ("seeds", "total_steps", "test_episodes"), where)
    says = problem(SEED, doc.get("seed", 0))
    if says:
        raise ConfigError(f"{where}: seed {says}")
    agents, rungs = [], []
    for name, a in doc["agents"].items():
        at = f"{where}: agents.{studyfile.name_of(name, where)}"
        if not isinstance(a, dict):
            raise ConfigError(f"{at} must be a mapping (label, settings)")
        studyfile.typed(a, AGENT_KEYS, at)
        only = a.get("rungs")
        if only is not None:
            unknown = [r for r in only if r not in doc["rungs"]]
            if unknown or not only:
                raise ConfigError(
                    f"{at}.rungs: no rung {unknown[0]!r}" if unknown else f"{at}.rungs is empty"
                )
            only = tuple(only)
        agents.append(Agent(name, a.get("label", name), flatten(a.get("settings", {})), only))
    for name, r in doc["rungs"].items():
        at = f"{where}: rungs.{studyfile.name_of(name, where)}"
        if not isinstance(r, dict) or "config" not in r:
            raise ConfigError(f"{at} must be a mapping with a config")
        studyfile.typed(r, RUNG_KEYS, at)
        if r.get("total_steps", 1) < 1:
            raise ConfigError(f"{at}: total_steps must be at least 1")
        if not (CONFIG_DIR / f"{r['config']}.yaml").is_file():
            raise ConfigError(f"{at}: no shipped config {r['config']!r} (jaxnav list shows them)")
        rung = Rung(
            name,
            r.get("label", name),
            r["config"],
            flatten(r.get("settings", {})),
            flatten(r.get("larger", {})),
            r.get("total_steps"),
        )
        rungs.append(rung)
    if not agents or not rungs:
        raise ConfigError(f"{where}: a study needs at least one agent and one rung")
    study = Study(
        title=doc["title"],
        seed=doc.get("seed", 0),
        seeds=doc["seeds"],
        total_steps=doc["total_steps"],
        test_episodes=doc.get("test_episodes", 10),
        strategies=tuple(doc["strategies"]),
        settings=flatten(doc.get("settings", {})),
        agents=tuple(agents),
        rungs=tuple(rungs),
        generalise_to=tuple(doc.get("generalise_to", [])),
        text=text,
        eval_points=doc.get("eval_points", 0),
    )
    for key in ("notes", "left_out"):
        if not all(isinstance(x, str) for x in doc.get(key, [])):
            raise ConfigError(f"{where}: {key} must be a list of lines of text")
    if study.eval_points < 0:
        raise ConfigError(f"{where}: eval_points must be 0 (none) or more")
    for name in study.generalise_to:  # tested after training: known before it
        try:
            make_maze(name)
        except JaxnavError as e:
            raise ConfigError(f"{where}: generalise_to: {e}") from None
    for rung, agent in study.cells():
        cfg = cell_config(study, rung, agent)
        if rung.larger:
            if not cfg.env.generator:
                raise ConfigError(f"{where}: rungs.{rung.name}.larger needs a drawn family")
            larger_config(cfg, rung)
    return study


def load_study(path: str, overrides: Sequence[str] = ()) -> Study:
    """The study of a file, with ``key=value`` overrides of its keys (dotted into its
    mappings: ``seeds=4``, ``settings.env.max_steps=100``,
    ``agents.pqn.settings.pqn.num_envs=64``; :func:`jaxnav.experiments.studyfile.read_text`)."""
    return studyfile.read_text(path, overrides, parse_study, STUDY_KEYS, ("settings", "larger"))


def cell_config(study: Study, rung: Rung, agent: Agent) -> Config:
    """A cell's config: the rung's shipped config, the study's settings, the agent's,
    the rung's, then the study's size (seeds, budget in env steps, tests)."""
    values = studyfile.base_values(rung.config)
    values.update(study.settings)
    if "agent" in agent.settings:  # another agent than the config's: not its sections
        reads = (
            agents.get(agent.settings["agent"]).reads
            if agent.settings["agent"] in agents.names()
            else ()
        )
        values = {
            k: v
            for k, v in values.items()
            if k.split(".")[0] not in agents.AGENT_SECTIONS or k.split(".")[0] in reads
        }
    values.update(agent.settings)
    values.update(rung.settings)
    values.pop("run.test_mazes", None)
    budget = rung.total_steps or study.total_steps
    values.update(
        {
            "seed": study.seed,
            "seeds": study.seeds,
            "strategies": list(study.strategies),
            "episodes": None,
            "total_steps": budget,
            "run.test_episodes": study.test_episodes,
        }
    )
    if study.eval_points:  # evaluations at equal shares of the budget, each a chunk's end
        every = budget // study.eval_points
        if every * study.eval_points != budget:
            raise ConfigError(
                f"rungs.{rung.name}: its budget of {budget} env steps does not split into "
                f"eval_points={study.eval_points} equal parts"
            )
        values.update({"run.eval_every": every, "run.chunk_steps": every})
    cfg = studyfile.build(values, f"rungs.{rung.name} with agents.{agent.name}")
    mazes = [] if cfg.env.generator else [cfg.env.maze]
    mazes += [m for m in study.generalise_to if m not in mazes]
    values["run.test_mazes"] = mazes
    return studyfile.build(values, f"rungs.{rung.name} with agents.{agent.name}")


def larger_config(cfg: Config, rung: Rung) -> Config:
    """The cell's config at the rung's larger size, drawing from the test split."""
    values = flatten(config_to_dict(cfg))
    values.pop("sweep", None)
    values.update(rung.larger)
    values["env.split"] = "test"
    return studyfile.build(values, f"rungs.{rung.name}.larger")


def tests_of(cfg: Config, rung: Rung) -> list[tuple[str, str]]:
    """(results maze name, test) of a cell: ``own`` (the world it trained on), ``test``
    (a family's unseen layouts), ``larger``, and each fixed generalisation maze."""
    out = []
    if cfg.env.generator:
        out += [(drawn_name(cfg, "train"), "own"), (drawn_name(cfg, "test"), "test")]
        if rung.larger:
            out.append((drawn_name(cfg, "larger"), "larger"))
    for m in cfg.run.test_mazes:
        out.append((m, "own" if m == cfg.env.maze and not cfg.env.generator else m))
    return out


def cell_dir(out: Path, rung: Rung, agent: Agent) -> Path:
    return out / "cells" / f"{rung.name}.{agent.name}"


def seed_scores(results_text: str, cfg: Config, rung: Rung, agent: Agent) -> list[dict]:
    """Per-seed greedy scores of every test of a cell (rows of :data:`SCORE_COLUMNS`)."""
    res = read_results(results_text, "greedy")
    rows = []
    # the learned arms, then the oracle and DWA where the test drove them
    drivers = list(cfg.run_labels())
    drivers += sorted({(k[1], k[2]) for k in res if baselines.is_baseline(k[1])})
    for maze, test in tests_of(cfg, rung):
        for strategy, seed in drivers:
            ep = res.get((maze, strategy, seed))
            if ep is None:  # diverged in training: not tested
                continue
            m = seed_metrics(ep)
            rows.append(
                {
                    "rung": rung.name,
                    "agent": agent.name,
                    "strategy": strategy,
                    "seed": seed,
                    "test": test,
                    "episodes": len(ep["return"]),
                    "attempts": int(np.sum(ep["attempts"])),
                    "return": f"{float(np.mean(ep['return'])):.6g}",
                    "success": f"{m['success']:.6g}",
                    "spl": f"{m['spl']:.6g}",
                    "collision": f"{m['collision']:.6g}",
                    "cut": f"{m['cut']:.6g}",
                    "goals_per_min": f"{m['goals_per_min']:.6g}",
                }
            )
    return rows


def curve_rows(metrics: list[dict[str, str]], rung: Rung, agent: Agent) -> list[dict]:
    """Training goals per episode (a moving mean over :data:`CURVE_WINDOW` episodes)
    against the share of the step budget: mean over seeds and a normal 95% band."""
    grid = np.linspace(0.0, 1.0, CURVE_POINTS)
    by: dict[tuple[str, int], list[tuple[int, float, float]]] = {}
    for r in metrics:
        key = (r["strategy"], int(r["seed"]))
        by.setdefault(key, []).append((int(r["episode"]), float(r["length"]), float(r["goals"])))
    rows = []
    for strategy in dict.fromkeys(k[0] for k in by):
        per_seed = []
        for (s, _), eps in sorted(by.items()):
            if s != strategy:
                continue
            eps.sort()
            steps = np.cumsum([e[1] for e in eps])
            goals = np.asarray([e[2] for e in eps])
            smooth = stats.moving_average(goals, CURVE_WINDOW)
            per_seed.append(np.interp(grid * steps[-1], steps, smooth))
        y = np.asarray(per_seed)
        mean = y.mean(0)
        half = 1.96 * y.std(0, ddof=1) / np.sqrt(len(y)) if len(y) > 1 else np.zeros_like(mean)
        for i, x in enumerate(grid):
            rows.append(
                {
                    "rung": rung.name,
                    "agent": agent.name,
                    "strategy": strategy,
                    "share": f"{x:.3f}",
                    "goals": f"{mean[i]:.5g}",
                    "low": f"{mean[i] - half[i]:.5g}",
                    "high": f"{mean[i] + half[i]:.5g}",
                }
            )
    return rows


def eval_rows(run: Path, rung: Rung, agent: Agent) -> list[dict]:
    """The cell's greedy evaluations while it trained (its ``eval.csv``), one row of
    :data:`EVAL_COLUMNS` per seed and evaluation; collision is the collisions' share of
    the decided attempts, as success is."""
    rows = []
    for r in CsvLog(run / EVAL, ()).read():
        decided = float(r["attempts"]) - float(r["cut"])
        collision = float(r["collisions"]) / decided if decided > 0 else float("nan")
        rows.append(
            {
                "rung": rung.name,
                "agent": agent.name,
                "strategy": r["strategy"],
                "seed": r["seed"],
                "env_step": r["env_step"],
                "wall_s": r["wall_s"],
                "success": r["success"],
                "collision": f"{collision:.6g}",
                **{c: r[c] for c in EXPLORED_COLUMNS if c in r},
            }
        )
    return rows


def run_cell(study: Study, out: Path, rung: Rung, agent: Agent, quiet: bool, say) -> None:
    """Train and test one cell unless it is done: its seeds.csv, curves.csv and
    cell.json (its row of cells.csv)."""
    cfg = cell_config(study, rung, agent)
    run = cell_dir(out, rung, agent)
    done = run / "seeds.csv"
    if done.is_file():
        return
    run.parent.mkdir(parents=True, exist_ok=True)
    cell = runner.Cell(f"{rung.name} / {agent.name}", cfg, run)
    train_s, _ = runner.train(cell, quiet, say)
    say(f"{cell.name}: testing {cfg.n_runs} policies, {study.test_episodes} episodes per test")
    t0 = time.perf_counter()
    more = {drawn_name(cfg, "larger"): larger_config(cfg, rung)} if rung.larger else None
    # the oracle and DWA drive a world's tests once, beside its first agent's policies
    first = agent.name == study.agents[0].name
    refs = baselines.names() if first else ()
    runner.test(cell, modes=("greedy",), more_drawn=more, references=refs)
    test_s = time.perf_counter() - t0
    summary = json.loads((run / "summary.json").read_text())
    row = {
        "rung": rung.name,
        "agent": agent.name,
        "runs": cfg.n_runs,
        "env_steps": int(summary["env_steps"]),
        "train_s": round(train_s, 1),
        "test_s": round(test_s, 1),
        "transitions_per_s": round(float(summary["steps_per_s"])),
        "compile_s": round(float(summary["compile_s"]), 1),
    }
    rows = seed_scores((run / "eval" / "results.csv").read_text(), cfg, rung, agent)
    curves = curve_rows(CsvLog(run / METRICS, ()).read(), rung, agent)
    atomic_write_text(
        run / "curves.csv", csv_text(list(curves[0]), [list(r.values()) for r in curves])
    )
    if study.eval_points:
        evals = eval_rows(run, rung, agent)
        head = list(evals[0]) if evals else list(EVAL_COLUMNS)
        atomic_write_text(run / "evals.csv", csv_text(head, [list(r.values()) for r in evals]))
    atomic_write_text(run / "cell.json", json.dumps(row))
    atomic_write_text(done, csv_text(SCORE_COLUMNS, [[r[c] for c in SCORE_COLUMNS] for r in rows]))


def run_study(study: Study, out: Path, resume_ok: bool, quiet: bool, command: str) -> Path:
    """Every cell, then ``DIR/data/``; returns the data folder."""
    runner.check_out(out, resume_ok, (out / "study.yaml", study.text))
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "study.yaml", study.text)
    if not (out / "command.txt").is_file():  # the command that started it, for the page
        atomic_write_text(out / "command.txt", command + "\n")

    say = runner.sayer("study", quiet)
    for k, (rung, agent) in enumerate(study.cells()):
        say(f"cell {k + 1} of {len(study.cells())}: {rung.name} with {agent.name}")
        run_cell(study, out, rung, agent, quiet, say)
    return write_data(study, out, command)


def _concat(paths: list[Path]) -> str:
    """CSV files with one header: the first's."""
    parts = [p.read_text() for p in paths]
    head = parts[0].splitlines(keepends=True)[0]
    return head + "".join("".join(t.splitlines(keepends=True)[1:]) for t in parts)


def write_data(study: Study, out: Path, command: str) -> Path:
    """The study's data files from its finished cells, into ``DIR/data/``."""
    data = out / "data"
    data.mkdir(exist_ok=True)
    dirs = [cell_dir(out, r, a) for r, a in study.cells()]
    atomic_write_text(data / "study.yaml", study.text)
    atomic_write_text(data / "scores.csv", _concat([d / "seeds.csv" for d in dirs]))
    atomic_write_text(data / "curves.csv", _concat([d / "curves.csv" for d in dirs]))
    if study.eval_points:
        atomic_write_text(data / "evals.csv", _concat([d / "evals.csv" for d in dirs]))
    cells = [json.loads((d / "cell.json").read_text()) for d in dirs]
    atomic_write_text(
        data / "cells.csv", csv_text(list(cells[0]), [list(c.values()) for c in cells])
    )
    started = out / "command.txt"
    run = {"command": started.read_text().strip() if started.is_file() else command}
    run["machine"] = runner.machine_line()
    atomic_write_text(data / "run.json", json.dumps(run, indent=1) + "\n")
    return data


def publish(study: Study, out: Path, page: Path) -> list[Path]:
    """The page, its figures and its data: ``page``, and beside it ``STEM-*.png`` and
    the folder ``STEM/`` with the data files."""
    data = out / "data"
    prefix = page.stem
    folder = page.parent / prefix
    folder.mkdir(parents=True, exist_ok=True)
    for name in DATA_FILES + tuple(n for n in LEARNING_FILES if (data / n).is_file()):
        shutil.copyfile(data / name, folder / name)
    written = study_pages.figures(folder, page.parent, prefix)
    traj = trajectory_cell(Data(folder))
    names = study_pages.figure_names(folder)
    if traj is not None and len(names) > 2:  # a page with a trajectory figure
        path = page.parent / f"{prefix}-{names[2]}"
        written.append(_trajectories(study, out, *traj, path))
    atomic_write_text(page, study_pages.page(folder, prefix))
    return [page, *written, folder]


def _trajectories(study: Study, out: Path, rung_name: str, agent_name: str, path: Path) -> Path:
    from jaxnav.report import plots

    rung = next(r for r in study.rungs if r.name == rung_name)
    agent = next(a for a in study.agents if a.name == agent_name)
    run = cell_dir(out, rung, agent)
    cfg, names, mazes, goal_radius, episodes, mode = plots.first_episodes(run)
    return plots.plot_trajectory(
        mazes[0], names[0], episodes[names[0]], cfg.seed, goal_radius, path, mode
    )
