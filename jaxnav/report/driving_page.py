"""The page of the policies that drive (``docs/driving.md``): each shipped ``drive_*``
config's committed run beside the oracle and DWA on the same test, from its data.

The data folder holds, per config, the run's ``results.csv`` (``jaxnav evaluate``'s,
the oracle's and DWA's rows in it) as ``NAME.csv`` and one row of ``runs.csv``: the
config, its world, the whole command's seconds (compilation included), its env steps
per run and its seeds. ``run.json`` names, per config, the tests its policies took
(each a list of ``env.KEY=VALUE`` settings; none: as trained): the first is
``NAME.csv``, the page's table; the k-th after it ``NAME.test{k+1}.csv``, a smaller
table of success under that test. Per world and test maze the page shows each driver's success,
collision, time-out, SPL and goals per minute (mean over seeds [95% CI]) and whether the
policies solve it (:func:`jaxnav.report.navigation.solved`, against the oracle's mean on
the very same test). No JAX: a test rebuilds the page from the committed data.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

import numpy as np

from jaxnav.core import baselines
from jaxnav.core.values import parse_override
from jaxnav.report import stats
from jaxnav.report.markdown import interval, markdown_table
from jaxnav.report.navigation import SOLVED_TOLERANCE, seed_metrics, solved
from jaxnav.report.results import ordered_unique, read_results

RUNS = "runs.csv"
EVALS = "evals"  # each config's greedy evaluations while it trained (eval.csv), NAME.csv
RUN_COLUMNS = ("config", "world", "command_s", "env_steps", "seeds", "strategy")
SHOWN = ("success", "collision", "timeout", "spl", "goals_per_min")
BEGIN, END = "<!-- driving: begin -->", "<!-- driving: end -->"


def _runs(folder: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO((folder / RUNS).read_text())))


def configs_of(folder: Path) -> list[str]:
    """The configs of a data folder's rows, in their order."""
    return [r["config"] for r in _runs(folder)]


def commands_of(meta: dict, configs: list[str]) -> dict[str, str]:
    """config -> the command that wrote its row, from a data folder's ``run.json``:
    ``{"commands": {config: command}, "machine": ...}``, or an earlier folder's one
    ``"command"`` for every config."""
    if "commands" in meta:
        return {c: meta["commands"][c] for c in configs if c in meta["commands"]}
    return dict.fromkeys(configs, meta["command"])


def config_tests(meta: dict, configs: list[str]) -> dict[str, list[list[str]]]:
    """config -> its tests' settings, from a data folder's ``run.json`` (``"tests"``);
    one test as trained for a config it does not name (folders written before tests)."""
    tests = meta.get("tests", {})
    return {c: [list(t) for t in tests.get(c, [[]])] for c in configs}


def data_name(config: str, k: int) -> str:
    """The data folder's file of a config's ``k``-th test (0: the page's table)."""
    return f"{config}.csv" if k == 0 else f"{config}.test{k + 1}.csv"


def setting_text(key: str, value: Any) -> str:
    """``key=value`` as a user types it (a plain string unquoted)."""
    plain = isinstance(value, str) and value and all(c.isalnum() or c in "._-" for c in value)
    return f"{key}={value if plain else json.dumps(value)}"


def label_of_test(test: list[str]) -> str:
    """A test as the page names it."""
    return " ".join(f"`{t}`" for t in test) if test else "as trained"


def trained_label(config: str, keys: list[str]) -> str:
    """ "as trained", naming the values the shipped ``config`` trained with of the
    ``keys`` (the table's test's settings, ``env.restart_goal=new``) where they differ."""
    from jaxnav.core.config import load_config

    cfg = load_config(config)
    shown = []
    for item in keys:
        key, _ = parse_override(item)
        section, name = key.split(".", 1)
        had = getattr(getattr(cfg, section), name)
        if setting_text(key, had) != item:
            shown.append(f"`{setting_text(key, had)}`")
    return "as trained" + (f" ({' '.join(shown)})" if shown else "")


def machines_of(meta: dict, configs: list[str]) -> dict[str, str]:
    """config -> the machine its row was measured on, from a data folder's ``run.json``
    (``"machines"``), or its one ``"machine"`` for every config (folders written before
    rows kept their own)."""
    if "machines" in meta:
        return {c: meta["machines"][c] for c in configs if c in meta["machines"]}
    return dict.fromkeys(configs, meta["machine"])


def written_by(commands: dict[str, str], machines: dict[str, str] | str) -> str:
    """The page's line naming each command and, when there are several, its configs;
    and the machine, or each command's machine when the rows were measured on several
    (``machines``: config -> machine, or one machine for all)."""
    if isinstance(machines, str):
        machines = dict.fromkeys(commands, machines)
    by: dict[tuple[str, str], list[str]] = {}
    for config, command in commands.items():
        by.setdefault((command, machines[config]), []).append(config)
    if len(by) == 1:
        command, machine = next(iter(by))
        return f"Written by `{command}` on {machine}."
    parts = {k: f"`{k[0]}` ({', '.join(f'`{n}`' for n in names)})" for k, names in by.items()}
    if len({m for _, m in by}) == 1:
        return f"Written by {'; '.join(parts.values())}, on {next(iter(by))[1]}."
    return "Written by " + "; ".join(f"{p} on {k[1]}" for k, p in parts.items()) + "."


def trained_worlds(config: str) -> tuple[str, ...] | None:
    """The worlds the shipped ``config`` trained across when it trained on a mix of
    them (``env.generator: mix``); None for a config of one world, which is tested on
    that world (or on its family's unseen layouts, which the test maze's split names)."""
    from jaxnav.core.config import load_config
    from jaxnav.core.errors import JaxnavError

    try:
        env = load_config(config, []).env
    except JaxnavError:  # not a shipped config any more: nothing to say
        return None
    return (*env.mix_worlds, "mix") if env.generator == "mix" else None


def world_table(folder: Path, k: int = 0) -> list[dict]:
    """One entry per (config, test maze): each driver's per-seed metrics and the run,
    in each config's ``k``-th test (the configs that took one)."""
    out = []
    for run in _runs(folder):
        path = folder / data_name(run["config"], k)
        if not path.is_file():
            continue
        trained = trained_worlds(run["config"])  # a maze of none of them: held out
        res = read_results(path.read_text())
        for maze in ordered_unique(k[0] for k in res):
            drivers = {}
            for name in (run["strategy"], *baselines.names()):
                seeds = sorted(k[2] for k in res if k[:2] == (maze, name))
                if seeds:
                    drivers[name] = [seed_metrics(res[(maze, name, s)]) for s in seeds]
            unseen = trained is not None and maze.split(":")[0] not in trained
            out.append({"run": run, "maze": maze, "drivers": drivers, "held_out": unseen})
    return out


def _mean(per_seed: list[dict], metric: str) -> float:
    x = np.asarray([m[metric] for m in per_seed], np.float64)
    return float(np.mean(x[np.isfinite(x)])) if np.isfinite(x).any() else float("nan")


def _cell(per_seed: list[dict], metric: str) -> str:
    x = np.asarray([m[metric] for m in per_seed], np.float64)
    x = x[np.isfinite(x)]
    if not len(x):
        return "n/a"
    return interval(stats.mean_ci(x), 1 if metric == "goals_per_min" else 2)


def sentences(folder: Path) -> list[str]:
    """One sentence per world and test maze: how close the shipped config drives to the
    oracle, generated from the data (the page lists them)."""
    out = []
    for e in world_table(folder):
        run, d = e["run"], e["drivers"]
        policy, oracle = d.get(run["strategy"]), d.get("oracle")
        if not policy or not oracle:
            continue
        ms, mo = _mean(policy, "success"), _mean(oracle, "success")
        where = run["world"] + ("" if e["maze"] == run["world"] else f" ({e['maze']})")
        if e["held_out"]:
            where = f"{e['maze']}, a kind of world it never trained on"
        verdict = "solves it" if solved(ms, mo) else "does not solve it"
        out.append(
            f"`{run['config']}` on {where}: success {ms:.3f} against the oracle's {mo:.3f}, "
            f"collisions {_mean(policy, 'collision'):.3f}, {len(policy)} seeds, "
            f"{float(run['command_s']):.0f} s for the whole command: it {verdict}."
        )
    return out


def line_of_tests(tests: dict[str, list[list[str]]]) -> str:
    """The page's line naming the table's test, and what its settings do."""
    from jaxnav.core.config import SETTINGS

    firsts = {c: t[0] for c, t in tests.items()}
    kinds = {tuple(t) for t in firsts.values()}
    if kinds == {()}:
        return "The policies are tested in the settings they trained in."
    if len(kinds) == 1:
        only = label_of_test(list(next(iter(kinds))))
        head = f"The table's test: the settings each config trained in, with {only}"
    else:
        head = "The table's test, per config: " + "; ".join(
            f"`{c}` {label_of_test(t)}" for c, t in firsts.items()
        )
    keys = dict.fromkeys(parse_override(item)[0] for t in kinds for item in t)
    what = " ".join(f"`{k}`: {SETTINGS[k].help}." for k in keys if k in SETTINGS)
    return f"{head}. {what}".strip()


def _same_results(folder: Path, config: str, k: int) -> bool:
    """Whether a config's ``k``-th test gave the very same results as the table's."""
    this = folder / data_name(config, k)
    return this.is_file() and this.read_bytes() == (folder / data_name(config, 0)).read_bytes()


def other_tests(folder: Path, tests: dict[str, list[list[str]]]) -> list[str]:
    """The smaller tables: per further test, the policies' and the oracle's success."""
    most = max((len(t) for t in tests.values()), default=1)
    if most < 2:
        return []
    rows, same = [], []
    for k in range(1, most):
        takers = {c: t for c, t in tests.items() if len(t) > k}
        alike = {c for c in takers if _same_results(folder, c, k)}
        same += [f"`{c}`" for c in takers if c in alike and f"`{c}`" not in same]
        labels = {
            c: label_of_test(t[k]) if t[k] else trained_label(c, t[0])
            for c, t in takers.items()
            if c not in alike
        }
        for e in world_table(folder, k):
            run, d = e["run"], e["drivers"]
            config = run["config"]
            policy, oracle = d.get(run["strategy"]), d.get("oracle")
            if config in alike or not policy:
                continue
            mo = _mean(oracle, "success") if oracle else float("nan")
            rows.append(
                [
                    f"`{config}`",
                    e["maze"],
                    labels[config],
                    str(len(policy)),
                    _cell(policy, "success"),
                    _cell(policy, "collision"),
                    _cell(oracle, "success") if oracle else "n/a",
                    "yes" if solved(_mean(policy, "success"), mo) else "no",
                ]
            )
    header = ["config", "test maze", "test", "seeds", "success", "collision",
              "oracle's success", "solved"]  # fmt: skip
    alike = (
        f" For {', '.join(same)} the other tests gave the very same results as the "
        "table's, episode for episode, and have no row here."
        if same
        else ""
    )
    return [
        "## The same policies in other tests",
        "",
        "The same trained policies, tested again in other settings (the oracle through "
        f"the same test), each cell as above.{alike}",
        "",
        *markdown_table(header, rows),
        "",
    ]


def driving_markdown(
    folder: Path,
    commands: dict[str, str],
    machines: dict[str, str] | str,
    tests: dict[str, list[list[str]]] | None = None,
) -> str:
    """The page from its data folder, the commands that wrote its rows (config ->
    command, :func:`commands_of`), the machines they ran on (config -> machine,
    :func:`machines_of`, or one for all) and each config's tests (:func:`config_tests`;
    None: one, as trained)."""
    tests = tests if tests is not None else config_tests({}, configs_of(folder))
    rows = []
    for e in world_table(folder):
        run, d = e["run"], e["drivers"]
        oracle = _mean(d["oracle"], "success") if "oracle" in d else float("nan")
        for name, per_seed in d.items():
            label = baselines.BASELINES[name].label if baselines.is_baseline(name) else "policy"
            is_policy = name == run["strategy"]
            verdict = ""
            if is_policy:
                verdict = "yes" if solved(_mean(per_seed, "success"), oracle) else "no"
            rows.append(
                [
                    f"`{run['config']}`" if is_policy else "",
                    (e["maze"] + (" (held out)" if e["held_out"] else "")) if is_policy else "",
                    label,
                    str(len(per_seed)),
                    *[_cell(per_seed, m) for m in SHOWN],
                    verdict,
                    f"{float(run['command_s']):.0f}" if is_policy else "",
                    f"{int(run['env_steps']):,}" if is_policy else "",
                ]
            )
    header = ["config", "test maze", "driver", "seeds", *SHOWN, "solved", "command (s)",
              "env steps per run"]  # fmt: skip
    L = [
        "# Policies that drive",
        "",
        "Each shipped `drive_*` config trains with the `modern` preset (what the field's "
        "navigation agents use, [driving.md sources](#the-recipe)) and is tested as every "
        "run is: `jaxnav evaluate`, its greedy test on the world's test mazes or a drawn "
        "family's unseen layouts, with the oracle and DWA driven through the very same test "
        "(the same seeds' test keys). Where a config gives its policies the maze's shortest "
        "path (`env.waypoint`, [worlds.md](worlds.md#the-path-as-a-global-planner-gives-it)), "
        "DWA follows it too. Each cell is the mean over seeds [95% bootstrap CI]; "
        "success, collision and time-out share the decided goal attempts "
        "([navigation metrics](reproducing.md#navigation-metrics)). *Solved*: the policies' "
        f"mean success is within {SOLVED_TOLERANCE} of the oracle's on the same test. "
        "*Command*: the whole `jaxnav train` command, compilation included (an empty "
        "compilation cache), on the machine named below for its row. *Held out*: a test "
        "maze of a kind of world that a config trained across several (`env.generator: "
        "mix`, `drive_anywhere`) never trained on.",
        "",
        written_by(commands, machines),
        "",
        line_of_tests(tests),
        "",
        *markdown_table(header, rows),
        "",
        "In one sentence each:",
        "",
        *[f"- {s}" for s in sentences(folder)],
        "",
        *other_tests(folder, tests),
        *recipe_section(),
    ]
    return "\n".join(L) + "\n"


def recipe_section() -> list[str]:
    """The ``modern`` preset's settings, each with its declared help (from the code)."""
    from jaxnav.core.config import SETTINGS
    from jaxnav.core.settings import PRESETS

    preset = PRESETS["modern"]
    values = {
        "dqn.gamma": preset.gamma,
        "env.R_plus": preset.R_plus,
        "env.R_minus": preset.R_minus,
        **preset.defaults,
    }
    rows = [
        [f"`{k}`", f"`{v}`", SETTINGS[k].help if k in SETTINGS else ""] for k, v in values.items()
    ]
    return [
        "## The recipe",
        "",
        "`preset: modern` sets these defaults (`jaxnav list` shows every setting); each "
        "`drive_*` config adds its world, seeds, budget and the settings it changes. Each "
        "is off in the `paper` preset, so the reproduction stays exact.",
        "",
        *markdown_table(["setting", "value", "what it does"], rows),
    ]


def readme_block(folder: Path) -> str:
    """The README's results, between its markers: how many of the configs' tests the
    policies solve, and each one they do not, against the oracle's success (the page
    has a sentence for every test)."""
    solved_n, missed = 0, []
    configs, seeds = set(), set()
    for e in world_table(folder):
        run, d = e["run"], e["drivers"]
        policy, oracle = d.get(run["strategy"]), d.get("oracle")
        if not policy or not oracle:
            continue
        configs.add(run["config"])
        seeds.add(len(policy))
        ms, mo = _mean(policy, "success"), _mean(oracle, "success")
        if solved(ms, mo):
            solved_n += 1
        else:
            kind = ", held out" if e["held_out"] else ""
            missed.append(f"`{run['config']}` on {e['maze']}{kind} ({ms:.3f} against {mo:.3f})")
    tested = solved_n + len(missed)
    text = (
        f"The {len(configs)} configs' policies, "
        f"{'-'.join(map(str, sorted(seeds)))} seeds each, come within "
        f"{SOLVED_TOLERANCE} of the oracle's success in {solved_n} of their {tested} tests"
    )
    return text + (f"; not in: {'; '.join(missed)}." if missed else ".")


__all__ = [
    "BEGIN",
    "END",
    "RUNS",
    "RUN_COLUMNS",
    "commands_of",
    "config_tests",
    "configs_of",
    "data_name",
    "driving_markdown",
    "machines_of",
    "readme_block",
    "sentences",
    "setting_text",
    "written_by",
]
