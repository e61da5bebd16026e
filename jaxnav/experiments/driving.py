"""The driving study (``kind: driving``): the policies that drive. Each shipped config
it names (``configs/studies/driving.yaml``: every ``drive_*`` config) is trained and
tested beside the oracle and DWA, into the page of :mod:`jaxnav.report.driving_page`.

Every config trains in one whole ``jaxnav train NAME`` command with an empty
compilation cache (its seconds, compilation included, are what the page reports), then
its policies are tested greedily (``jaxnav evaluate RUN --episodes N``: the oracle's and
DWA's rows on the same test keys). A cell is a config: ``DIR/NAME/`` is its run,
``DIR/NAME/command_s.json`` the command's seconds. A finished cell is reused (a run
trained with other settings than the config's now is refused); a training that was
interrupted is refused, as its time would not be one command's.

``tests:`` lists the tests each config's policies take, each a mapping of environment
settings to test in (``jaxnav evaluate RUN env.KEY=VALUE``; ``{}``: the settings they
trained in). The first is the page's table and its sentences; each further one is a
smaller table beside it (the policies' and the oracle's success under that test). A
test's results are ``DIR/NAME/eval/`` (``{}``) or ``DIR/NAME/eval-KEY=VALUE/``, so a
finished test is reused and a new test runs on the finished training.

Extra names on the command line pick configs (``jaxnav study driving drive_grid4 --out
runs/drive``); the page's data folder keeps the other configs' rows, so one config can be
run again alone. ``--doc docs/driving.md`` writes the committed page and its data,
``docs/driving/`` (each config's test results, its row, and its greedy evaluations while
it trained, ``evals/NAME.csv``), with the figure of SAC beside PQN
(:mod:`jaxnav.report.agents_sac`); ``jaxnav publish driving-page driving agents-sac``
rewrites the page, the README's results lines and docs/agents.md's SAC table from that
data alone.
"""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from jaxnav.core.config import Config
from jaxnav.core.errors import ConfigError, JaxnavError
from jaxnav.core.rundir import EVAL, atomic_write_text, csv_text
from jaxnav.core.shipped import CONFIG_DIR
from jaxnav.core.values import flatten, parse_override
from jaxnav.experiments import runner, studyfile
from jaxnav.experiments.evaluation import test_overrides
from jaxnav.report import agents_sac
from jaxnav.report.driving_page import (
    EVALS,
    RUN_COLUMNS,
    RUNS,
    commands_of,
    config_tests,
    configs_of,
    data_name,
    driving_markdown,
    machines_of,
    setting_text,
)

STUDY_KEYS = {
    "kind": str,
    "title": str,
    "configs": list,
    "test_episodes": int,
    "settings": dict,
    "tests": list,
    "cost": str,  # what a whole run of it took, measured (jaxnav list studies)
}
REQUIRED = ("kind", "title", "configs")
TIMING = "command_s.json"  # in a cell's run: the whole training command's seconds


@dataclass(frozen=True)
class Study:
    title: str
    configs: tuple[str, ...]  # shipped configs' names
    test_episodes: int
    settings: dict[str, Any]  # over every config (a small form: settings.total_steps=2048)
    text: str  # the study file, as read
    tests: tuple[tuple[str, ...], ...] = ((),)  # each test's env.KEY=VALUE settings

    def overrides(self) -> list[str]:
        """The settings as ``jaxnav train``'s ``key=value`` arguments."""
        return [f"{k}={json.dumps(v)}" for k, v in self.settings.items()]


def parse_tests(tests: list, where: str) -> tuple[tuple[str, ...], ...]:
    """The study's ``tests``: each a mapping of environment settings, as ``key=value``
    overrides of ``jaxnav evaluate``."""
    if not tests:
        raise ConfigError(f"{where}: tests must list at least one test ({{}}: as trained)")
    out = []
    for k, test in enumerate(tests):
        if not isinstance(test, dict):
            raise ConfigError(
                f"{where}: tests[{k}] must be a mapping of settings ({{}}: as trained), "
                f"not {test!r}"
            )
        try:
            items = tuple(setting_text(key, v) for key, v in flatten(test).items())
            test_overrides(items)
        except ConfigError as e:
            raise ConfigError(f"{where}: tests[{k}]: {e}") from None
        out.append(items)
    if len(set(out)) < len(out):
        raise ConfigError(f"{where}: tests names a test twice")
    return tuple(out)


def results_folder(test: tuple[str, ...] | list[str]) -> str:
    """A test's results folder in a run: ``eval`` as trained, else ``eval-KEY=VALUE``
    (several joined by ``,``), so each test's results are kept apart and reused."""
    if not test:
        return "eval"
    return "eval-" + ",".join(t.replace("/", "_") for t in test)


def parse_study(text: str, where: str) -> Study:
    """A driving study from its YAML text; every config is built, so a wrong name or
    setting is one line here, before any training."""
    doc = studyfile.mapping(text, where)
    studyfile.typed(doc, STUDY_KEYS, where)
    studyfile.required(doc, REQUIRED, where)
    studyfile.at_least_one(doc, ("test_episodes",), where)
    configs = doc["configs"]
    if not configs or not all(isinstance(c, str) for c in configs):
        raise ConfigError(f"{where}: configs must list shipped configs' names")
    for name in configs:
        if not (CONFIG_DIR / f"{name}.yaml").is_file():
            raise ConfigError(f"{where}: no shipped config {name!r} (jaxnav list shows them)")
    if len(set(configs)) < len(configs):
        raise ConfigError(f"{where}: configs names a config twice")
    study = Study(
        doc["title"],
        tuple(configs),
        doc.get("test_episodes", 10),
        flatten(doc.get("settings", {})),
        text,
        parse_tests(doc.get("tests", [{}]), where),
    )
    for name in study.configs:
        config_of(study, name, where)
        for test in filter(None, study.tests):
            config_of(study, name, where, test)
    return study


def load_study(path: str, items: list[str] | tuple[str, ...] = ()) -> Study:
    """The study of a file; ``items``: ``key=value`` overrides of its keys, and configs'
    names, which replace its list (``drive_grid4``: that config alone)."""
    names = [i for i in items if "=" not in i]
    overrides = [i for i in items if "=" in i]
    if names:
        overrides.append(f"configs={json.dumps(names)}")
    return studyfile.read_text(path, overrides, parse_study, STUDY_KEYS)


def config_of(study: Study, name: str, where: str = "study", test: tuple[str, ...] = ()) -> Config:
    """A config as the study trains it, or in a test's settings (``test``: a setting
    the config cannot take is one line here, before any training)."""
    values = studyfile.base_values(name)
    values.update(study.settings)
    values.update(parse_override(item) for item in test)
    tested = f" tested with {' '.join(test)}" if test else ""
    return studyfile.build(values, f"{where}: configs.{name}{tested}")


def world_of(cfg: Config) -> str:
    e = cfg.env
    return (
        f"{e.generator} {e.grid_rows}x{e.grid_cols}"
        if e.generator == "grid"
        else (e.generator or e.maze)
    )


def train_command(study: Study, name: str, run: Path) -> float:
    """``jaxnav train NAME`` into ``run``, in its own process with an empty compilation
    cache; the whole command's wall seconds."""
    argv = [sys.executable, "-m", "jaxnav", "train", name, *study.overrides()]
    argv += ["--out", str(run), "--yes", "--quiet"]
    with tempfile.TemporaryDirectory() as cache:
        t0 = time.perf_counter()
        done = subprocess.run(argv, env={**os.environ, "JAXNAV_CACHE": cache})
        seconds = time.perf_counter() - t0
    if done.returncode != 0:
        raise JaxnavError(f"jaxnav train {name} failed (exit status {done.returncode})")
    return seconds


def run_cell(study: Study, out: Path, name: str, say: runner.Say) -> dict:
    """Train (the whole command, an empty compilation cache) and test one config unless
    done; its row of the page's runs.csv."""
    cfg = config_of(study, name)
    cell = runner.Cell(name, cfg, out / name)
    timing = cell.run / TIMING
    if cell.run.exists():
        runner.check_settings(cell)
    if not (cell.run / "summary.json").is_file():
        if cell.run.exists():
            raise JaxnavError(
                f"{cell.run} was interrupted: its time would not be one command's; "
                "remove it and run again"
            )
        say(f"{name}: training (the whole command, an empty compilation cache)")
        seconds = train_command(study, name, cell.run)
        atomic_write_text(timing, json.dumps({"command_s": round(seconds, 1)}))
    if not timing.is_file():
        raise JaxnavError(f"{cell.run} has no {TIMING}: it was not trained by this study")
    for test in study.tests:
        folder = cell.run / results_folder(test)
        if not (folder / "results.csv").is_file():
            how = f", with {' '.join(test)}" if test else ""
            say(
                f"{name}: testing {cfg.n_runs} policies, {study.test_episodes} episodes "
                f"per maze{how}"
            )
            runner.test(cell, n_episodes=study.test_episodes, out=folder, overrides=test)
    summary = json.loads((cell.run / "summary.json").read_text())
    return {
        "config": name,
        "world": world_of(cfg),
        "command_s": json.loads(timing.read_text())["command_s"],
        "env_steps": int(summary["env_steps"]) // cfg.n_runs,
        "seeds": cfg.seeds,
        "strategy": cfg.strategies[0],
    }


def run_study(study: Study, out: Path, resume_ok: bool, quiet: bool, command: str) -> Path:
    """Every config, then ``DIR/data/``: each config's results (``NAME.csv``), their rows
    of runs.csv and run.json (the command and the machine); returns the data folder."""
    runner.check_out(out, resume_ok)  # a cell checks its own run's settings
    out.mkdir(parents=True, exist_ok=True)
    say = runner.sayer("study", quiet)
    rows = []
    for k, name in enumerate(study.configs):
        say(f"config {k + 1} of {len(study.configs)}: {name}")
        rows.append(run_cell(study, out, name, say))
    data = out / "data"
    data.mkdir(exist_ok=True)
    (data / EVALS).mkdir(exist_ok=True)
    for name in study.configs:
        for k, test in enumerate(study.tests):
            shutil.copyfile(
                out / name / results_folder(test) / "results.csv", data / data_name(name, k)
            )
        if (out / name / EVAL).is_file():  # the greedy evaluations while it trained
            shutil.copyfile(out / name / EVAL, data / EVALS / f"{name}.csv")
    atomic_write_text(
        data / RUNS, csv_text(RUN_COLUMNS, [[r[c] for c in RUN_COLUMNS] for r in rows])
    )
    machine = runner.machine_line()
    meta = {
        "commands": dict.fromkeys(study.configs, command),
        "machines": dict.fromkeys(study.configs, machine),
        "tests": {c: [list(t) for t in study.tests] for c in study.configs},
        "machine": machine,
    }
    atomic_write_text(data / "run.json", json.dumps(meta) + "\n")
    return data


def _rows(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text()))) if path.is_file() else []


SHIPPED = CONFIG_DIR / "studies" / "driving.yaml"


def shipped_order() -> list[str]:
    """The shipped study's configs (``configs/studies/driving.yaml``), in its order."""
    return list(yaml.safe_load(SHIPPED.read_text())["configs"])


def publish(study: Study, out: Path, page: Path) -> list[Path]:
    """The page and its data folder ``STEM/`` beside it: this study's configs' results
    and rows, the rows of configs it did not run kept from the folder."""
    data, folder = out / "data", page.parent / page.stem
    folder.mkdir(parents=True, exist_ok=True)
    rows = {r["config"]: r for r in _rows(folder / RUNS)}
    (folder / EVALS).mkdir(exist_ok=True)
    new = json.loads((data / "run.json").read_text())
    ran = configs_of(data)
    ran_tests = config_tests(new, ran)
    for r in _rows(data / RUNS):
        rows[r["config"]] = r
        for old in folder.glob(f"{r['config']}.test*.csv"):  # an earlier run's other tests
            old.unlink()
        for k in range(len(ran_tests[r["config"]])):
            name = data_name(r["config"], k)
            shutil.copyfile(data / name, folder / name)
        if (data / EVALS / f"{r['config']}.csv").is_file():
            shutil.copyfile(
                data / EVALS / f"{r['config']}.csv", folder / EVALS / f"{r['config']}.csv"
            )
    # in the shipped study's order (a config run alone goes to its place, not the end);
    # rows of configs it does not list follow, in the folder's order
    order = {name: i for i, name in enumerate(shipped_order())}
    rows = dict(sorted(rows.items(), key=lambda kv: order.get(kv[0], len(order))))
    text = csv_text(RUN_COLUMNS, [[r[c] for c in RUN_COLUMNS] for r in rows.values()])
    atomic_write_text(folder / RUNS, text)
    # each row keeps the command that wrote it: the folder's for the rows kept
    kept = json.loads((folder / "run.json").read_text()) if (folder / "run.json").is_file() else {}
    configs = list(rows)
    commands = {**(commands_of(kept, configs) if kept else {}), **commands_of(new, ran)}
    commands = {c: commands[c] for c in configs}
    machines = {**(machines_of(kept, configs) if kept else {}), **machines_of(new, ran)}
    machines = {c: machines[c] for c in configs}
    tests = {**config_tests(kept, configs), **ran_tests}
    tests = {c: tests[c] for c in configs}
    meta = {"commands": commands, "machines": machines, "tests": tests, "machine": new["machine"]}
    atomic_write_text(folder / "run.json", json.dumps(meta) + "\n")
    atomic_write_text(page, driving_markdown(folder, commands, machines, tests))
    written = [page]
    if agents_sac.pairs(folder):  # SAC beside PQN: docs/agents.md's figure
        written.append(agents_sac.figure(folder, page.parent / agents_sac.FIGURE))
    return [*written, folder]  # the data folder last, as every study's publish
