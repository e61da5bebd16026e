"""A sim-to-sim campaign (``kind: sim2sim``): arms of one config, each trained with
its own settings, every policy tested greedily in jaxnav and in MuJoCo, into one table
of which arm narrows the gap (:func:`jaxnav.report.sim2sim_tables.campaign_markdown`).

``configs/studies/sim2sim_realism.yaml`` trains the no-obstacle paper config once per
realism option; ``configs/studies/sim2sim_wheel_limit.yaml`` trains it without and with
the burger's firmware wheel limits and tests in MuJoCo with them. An arm (``arms:``) has

* ``settings`` over the config and the study's ``settings`` (none: the config as it is);
* ``run``: an existing run of the same config to test instead of training one (its
  first ``seeds`` seeds), as ``arms.plain.run=RUN_DIR``;
* ``policies``: another arm's name, whose run it tests (in MuJoCo with other options);
* ``wheel_limit``: MuJoCo clips the burger's commands as its firmware does;
* ``label``: what the page says the arm is (default: its settings).

Each arm is a cell of the study runner (:mod:`jaxnav.experiments.runner`): ``DIR/ARM/``
its run, ``DIR/ARM/sim2sim/sim2sim.csv`` its MuJoCo test (``jaxnav sim2sim`` in its own
process, beside the next arm's training; its log ``DIR/ARM/sim2sim.log``). A finished
step is reused, so an interrupted campaign resumes (``--resume``). The data
(``DIR/data/campaign.csv``, every arm's rows with an ``option`` column first, and
``campaign.json``, how it was made) goes beside the page, ``STEM.csv`` and ``STEM.json``;
``jaxnav publish`` rewrites the committed pages from them alone.
"""

from __future__ import annotations

import csv
import importlib.util
import json
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from jaxnav.core import rundir
from jaxnav.core.config import Config
from jaxnav.core.errors import ConfigError, JaxnavError
from jaxnav.core.rundir import atomic_write_text, csv_text
from jaxnav.core.shipped import CONFIG_DIR
from jaxnav.core.values import flatten
from jaxnav.experiments import runner, studyfile
from jaxnav.report.sim2sim_tables import REALISM_COLUMNS, campaign_markdown

STUDY_KEYS = {
    "kind": str,
    "title": str,
    "config": str,
    "seeds": int,
    "episodes": int,
    "settings": dict,
    "arms": dict,
    "note": str,
    "cost": str,  # what a whole run of it took, measured (jaxnav list studies)
}
REQUIRED = ("kind", "title", "config", "seeds", "episodes", "arms")
ARM_KEYS = {"label": str, "settings": dict, "run": str, "policies": str, "wheel_limit": bool}
DATA = ("campaign.csv", "campaign.json")  # in DIR/data/; beside the page as STEM.csv, .json


@dataclass(frozen=True)
class Arm:
    name: str
    label: str  # "" for none: the page shows its settings
    settings: dict[str, Any]
    run: str | None  # an existing run to test instead of training
    policies: str | None  # another arm whose run it tests
    wheel_limit: bool

    def trains(self) -> bool:
        """Whether the arm trains a run of its own (neither ``run`` nor ``policies``)."""
        return self.run is None and self.policies is None


@dataclass(frozen=True)
class Study:
    title: str
    config: str
    seeds: int
    episodes: int
    settings: dict[str, Any]
    arms: tuple[Arm, ...]
    note: str
    text: str  # the study file, as read


def parse_study(text: str, where: str) -> Study:
    """A campaign from its YAML text; every arm's config is built, so a wrong setting
    is one line here, before any training."""
    doc = studyfile.mapping(text, where)
    studyfile.typed(doc, STUDY_KEYS, where)
    studyfile.required(doc, REQUIRED, where)
    studyfile.at_least_one(doc, ("seeds", "episodes"), where)
    if not (CONFIG_DIR / f"{doc['config']}.yaml").is_file():
        raise ConfigError(f"{where}: no shipped config {doc['config']!r} (jaxnav list shows them)")
    arms: list[Arm] = []
    for name, a in doc["arms"].items():
        at = f"{where}: arms.{studyfile.name_of(name, where)}"
        a = {} if a is None else a
        if not isinstance(a, dict):
            raise ConfigError(f"{at} must be a mapping (label, settings, run, policies, ...)")
        studyfile.typed(a, ARM_KEYS, at)
        policies = a.get("policies")
        if policies is not None and policies not in [x.name for x in arms if x.trains()]:
            raise ConfigError(f"{at}: policies must name an arm above it that trains")
        if policies is not None and (a.get("settings") or a.get("run")):
            raise ConfigError(f"{at}: an arm that tests {policies}'s policies trains nothing")
        arms.append(
            Arm(
                name,
                a.get("label", ""),
                flatten(a.get("settings", {})),
                a.get("run"),
                policies,
                a.get("wheel_limit", False),
            )
        )
    if not arms:
        raise ConfigError(f"{where}: a campaign needs at least one arm")
    study = Study(
        doc["title"],
        doc["config"],
        doc["seeds"],
        doc["episodes"],
        flatten(doc.get("settings", {})),
        tuple(arms),
        doc.get("note", ""),
        text,
    )
    for arm in study.arms:
        arm_config(study, arm)
    return study


def load_study(path: str, overrides: list[str] | tuple[str, ...] = ()) -> Study:
    """The campaign of a file, with ``key=value`` overrides (``seeds=2``,
    ``episodes=1``, ``arms.plain.run=RUN_DIR``, ``settings.episodes=20``)."""
    return studyfile.read_text(path, overrides, parse_study, STUDY_KEYS, ("settings", "arms"))


def arm_config(study: Study, arm: Arm) -> Config:
    """An arm's config: the study's config, its settings, the arm's, ``seeds``."""
    if arm.policies is not None:
        arm = next(a for a in study.arms if a.name == arm.policies)
    values = studyfile.base_values(study.config)
    values.update(study.settings)
    values.update(arm.settings)
    values["seeds"] = study.seeds
    return studyfile.build(values, f"arms.{arm.name}")


def arm_run(study: Study, out: Path, arm: Arm) -> Path:
    """The run an arm tests: its own ``DIR/ARM``, the ``run`` it names, or its
    ``policies`` arm's."""
    if arm.run is not None:
        return Path(arm.run)
    return out / (arm.policies or arm.name)


def _check_mujoco() -> None:
    if importlib.util.find_spec("mujoco") is None:
        raise JaxnavError(
            "a sim2sim campaign needs MuJoCo: pip install -e \".[sim]\" (the optional extra 'sim')"
        )


def start_test(argv: list[str], log: Path) -> subprocess.Popen:
    """A MuJoCo test in its own process (only ``jaxnav sim2sim`` imports MuJoCo), its
    output into ``log``."""
    with open(log, "w") as f:
        return subprocess.Popen(argv, stdout=f, stderr=subprocess.STDOUT)


def run_study(study: Study, out: Path, resume_ok: bool, quiet: bool, command: str) -> Path:
    """Every arm trained (or reused) and tested in MuJoCo, each test beside the next
    arm's training, then ``DIR/data/``; returns the data folder."""
    _check_mujoco()
    for arm in study.arms:  # a run to reuse is checked before any training
        if arm.run is not None:
            rundir.existing(arm.run, finished=True)
    runner.check_out(out, resume_ok, (out / "study.yaml", study.text))
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "study.yaml", study.text)
    atomic_write_text(out / "commit", runner.code_version() + "\n")  # the code that runs
    if not (out / "command.txt").is_file():  # the command that started it, for the page
        atomic_write_text(out / "command.txt", command + "\n")
    say = runner.sayer("study", quiet)
    pending: list[tuple[Arm, subprocess.Popen]] = []
    try:
        for k, arm in enumerate(study.arms):
            say(f"arm {k + 1} of {len(study.arms)}: {arm.name}")
            cfg, run = arm_config(study, arm), arm_run(study, out, arm)
            if arm.trains():
                runner.train(runner.Cell(arm.name, cfg, run), quiet, say)
            test = out / arm.name / "sim2sim" / "sim2sim.csv"
            if not test.is_file():
                test.parent.mkdir(parents=True, exist_ok=True)
                seeds = [cfg.seed + s for s in range(study.seeds)]
                argv = runner.sim2sim_argv(run, seeds, study.episodes, test, arm.wheel_limit)
                say(f"{arm.name}: testing in MuJoCo beside the next step")
                pending.append((arm, start_test(argv, out / arm.name / "sim2sim.log")))
        for arm, proc in pending:
            if proc.wait() != 0:
                raise JaxnavError(
                    f"the MuJoCo test of {arm.name} failed: {_last_line(out / arm.name)}"
                )
    finally:
        for _, proc in pending:  # an error or Ctrl-C: no test left running unseen
            if proc.poll() is None:
                proc.terminate()
                proc.wait()
    return write_data(study, out)


def _last_line(arm_dir: Path) -> str:
    lines = (arm_dir / "sim2sim.log").read_text().strip().splitlines()
    return lines[-1] if lines else "no output"


def _mujoco_minutes(arm_dir: Path) -> float:
    """The MuJoCo test's minutes, from the per-maze lines of its log."""
    log = (arm_dir / "sim2sim.log").read_text().strip().splitlines()
    seconds = sum(
        int(line.rsplit(", ", 1)[1].removesuffix(" s")) for line in log if " in MuJoCo, " in line
    )
    return round(seconds / 60, 1)


def _shown(study: Study, arm: Arm) -> str:
    if arm.label:
        return arm.label
    if not arm.settings:
        return f"`none (configs/{study.config}.yaml as it is)`"
    return " ".join(
        f"`{k}={json.dumps(v, separators=(',', ':'))}`" for k, v in arm.settings.items()
    )


def how_made(study: Study, out: Path, cfg: Config) -> str:
    """The page's paragraph on how the campaign was made."""
    commit = (out / "commit").read_text().strip()
    command = (out / "command.txt").read_text().strip()
    budget = f"{cfg.episodes} episodes" if cfg.episodes is not None else ""
    if cfg.total_steps is not None:
        budget += (" or " if budget else "") + f"{cfg.total_steps:,} env steps"
    last = cfg.seed + study.seeds - 1
    text = (
        f"`{command}` trains configs/{study.config}.yaml once per arm that trains "
        f"({study.seeds} seeds per strategy, {budget}) and tests every policy greedily in "
        f"jaxnav (in the run's own settings) and in MuJoCo (`jaxnav sim2sim RUN --seeds "
        f"{cfg.seed} .. {last} --episodes {study.episodes}`, with `--wheel-limit` where "
        f"the arm says so), with the code at {commit}. Each MuJoCo test ran beside the "
        "next arm's training on the same machine, so the times below are slower than "
        "either alone. `jaxnav publish` rewrites this page from the CSV and the JSON "
        "beside it."
    )
    return f"{text} {study.note.strip()}" if study.note.strip() else text


def write_data(study: Study, out: Path) -> Path:
    """``DIR/data/campaign.csv`` (every arm's MuJoCo test, an ``option`` column first)
    and ``campaign.json`` (the title, how it was made, each arm's times)."""
    rows, made = [], []
    for arm in study.arms:
        with open(out / arm.name / "sim2sim" / "sim2sim.csv") as f:
            rows += [[arm.name, *r.values()] for r in csv.DictReader(f)]
        summary = out / arm.name / "summary.json"
        train_min = None
        if arm.trains():
            train_min = round(json.loads(summary.read_text())["wall_clock_s"] / 60, 1)
        reused = f"{arm.policies}'s run" if arm.policies else "an earlier run"
        made.append(
            {
                "arm": arm.name,
                "what": _shown(study, arm),
                "train_min": train_min,
                "reused": None if arm.trains() else reused,
                "mujoco_min": _mujoco_minutes(out / arm.name),
            }
        )
    column = "arm" if any(a.label for a in study.arms) else "override"
    meta = {
        "title": study.title,
        "how": how_made(study, out, arm_config(study, study.arms[0])),
        "column": column,
        "arms": made,
    }
    data = out / "data"
    data.mkdir(exist_ok=True)
    atomic_write_text(data / DATA[0], csv_text(REALISM_COLUMNS, rows))
    atomic_write_text(data / DATA[1], json.dumps(meta, indent=1) + "\n")
    return data


def publish(study: Study, out: Path, page: Path) -> list[Path]:
    """The page, and beside it its data: ``STEM.csv`` and ``STEM.json``."""
    data = out / "data"
    csv_path, json_path = page.with_suffix(".csv"), page.with_suffix(".json")
    shutil.copyfile(data / DATA[0], csv_path)
    shutil.copyfile(data / DATA[1], json_path)
    atomic_write_text(
        page, campaign_markdown(csv_path.read_text(), json.loads(json_path.read_text()))
    )
    return [page, csv_path, json_path]
