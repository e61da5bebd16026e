"""``jaxnav reproduce [--seeds N] [--out DIR] [--quick] [--resume]``

The paper's two experiments end to end: train ``configs/paper_no_obstacles.yaml``
(Table 3, Fig. 2) and ``configs/paper_obstacles.yaml`` (Table 4, Fig. 4), both
strategies and N seeds each, test them (``jaxnav evaluate``), draw the figures
(``jaxnav.report.plots``) and write ``DIR/report.md`` with the tables, the figures, the
wall-clock of every stage and the machine.

Default: 8 seeds per strategy (the paper configs' own) and the paper's 500
episodes of at most 500 steps: 18 minutes in all, measured on 2 shared CPU cores
(AMD EPYC) with one CPU device per core, 13.7 of them training without obstacles
and 3.7 with (episodes end sooner there); ``--seeds 4`` takes about half.
Each experiment's policies are also tested under sensor perturbations on its
training maze (``jaxnav evaluate --robustness``). The paper's claims compare the two
strategies, so the reference drivers that ``jaxnav evaluate`` drives beside a run's
policies (the oracle and DWA) are left out of the test; ``--baselines`` adds them.

``--quick``: 2 seeds, 50 episodes of at most 200 steps, 3 test episodes: about 1.5
minutes with the robustness stage, for checking that everything runs (its numbers mean little).
``--episodes``, ``--max-steps``, ``--test-episodes`` override those sizes (tests use
them for a tiny end-to-end run). ``--resume`` continues an interrupted
reproduction in DIR: finished trainings are reused, an unfinished one resumes from
its last checkpoint, evaluation and figures are redone. Each experiment is a cell of
the study runner (:mod:`jaxnav.experiments.runner`): trained, reused, resumed or
refused and tested by the same rule as every study's cells.

Layout::

    DIR/report.md
    DIR/paper_no_obstacles/   a training run (see jaxnav train) + eval/ + plots/
    DIR/paper_obstacles/
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import time
from pathlib import Path

from jaxnav.core import baselines as reference_drivers
from jaxnav.core.config import Config, load_config
from jaxnav.core.errors import JaxnavError
from jaxnav.core.rundir import METRICS, CsvLog, atomic_write_text
from jaxnav.core.shipped import CONFIG_DIR
from jaxnav.experiments import runner
from jaxnav.experiments.robustness import robustness_to_dir
from jaxnav.report import plots
from jaxnav.report.claims import claims_markdown, evaluate_claims
from jaxnav.report.tables import training_markdown

DEFAULT_SEEDS = 8
QUICK = {"seeds": 2, "episodes": 50, "max_steps": 200, "test_episodes": 3}
EXPERIMENTS = (
    (
        "paper_no_obstacles",
        "Trained on square4 without obstacles (paper Sec. 6.1, Table 3, Fig. 2)",
    ),
    ("paper_obstacles", "Trained on square4 with obstacles (paper Sec. 6.2, Table 4, Fig. 4)"),
)


def experiment_config(
    name: str,
    seeds: int,
    episodes: int | None,
    max_steps: int | None,
    test_episodes: int | None,
    extra: tuple[str, ...] = (),
):
    """An experiment's config at the requested size; ``extra``: more overrides."""
    overrides = [f"seeds={seeds}", *extra]
    if episodes is not None:
        overrides.append(f"episodes={episodes}")
    if max_steps is not None:
        overrides.append(f"env.max_steps={max_steps}")
    if test_episodes is not None:
        overrides.append(f"run.test_episodes={test_episodes}")
    cfg = load_config(str(CONFIG_DIR / f"{name}.yaml"), overrides)
    # A chunk longer than a seed's whole run only computes masked steps.
    if cfg.run.chunk_steps > cfg.max_total_steps:
        cfg = load_config(
            str(CONFIG_DIR / f"{name}.yaml"), overrides + [f"run.chunk_steps={cfg.max_total_steps}"]
        )
    return cfg


def _demote(md: str, levels: int = 2) -> str:
    return re.sub(r"^(#+) ", lambda m: "#" * (len(m.group(1)) + levels) + " ", md, flags=re.M)


def _fmt_s(s: float) -> str:
    return f"{s:.1f} s" if s < 120 else f"{s:.1f} s ({s / 60:.1f} min)"


def write_report(
    out: Path,
    info: dict,
    settings: dict,
    timings: list[tuple[str, float, str]],
    sections: list[str],
    claims: str,
) -> Path:
    total = sum(t for _, t, _ in timings)
    L = ["# jaxnav: reproduction of Usama & Chang (2019), EBE vs epsilon-greedy", ""]
    L += [f"Command: `{settings['command']}`, finished {time.strftime('%Y-%m-%d %H:%M:%S')}.", ""]
    quick = " (--quick: a smoke test, not a reproduction)" if settings["quick"] else ""
    L += [
        f"Settings: {settings['seeds']} seeds per strategy, {settings['episodes']} training "
        f"episodes of at most {settings['max_steps']} steps per seed, "
        f"{settings['test_episodes']} consecutive test episodes per seed and maze{quick}. "
        "The rest of each config is the paper's (configs/paper_*.yaml; each run's full "
        "config.yaml is in its directory). The paper shows one training run per strategy; the "
        f"seeds here show whether a difference holds (default {DEFAULT_SEEDS}).",
        "",
        _demote(claims, 1).rstrip(),
        "",
        "## Machine",
        "",
        "| | |",
        "|---|---|",
    ]
    L += [f"| {k} | {v} |" for k, v in info.items()]
    L += ["", "## Wall-clock", "", "| stage | time | note |", "|---|---|---|"]
    L += [f"| {name} | {_fmt_s(t)} | {note} |" for name, t, note in timings]
    L += [f"| **total** | **{_fmt_s(total)}** | |", ""]
    L += [
        "Training time includes compiling (tens of seconds per config); timings on a shared "
        "machine are noisy.",
        "",
    ]
    L += sections
    path = out / "report.md"
    atomic_write_text(path, "\n".join(L) + "\n")
    return path


def _experiment(
    name: str,
    title: str,
    cfg: Config,
    out: Path,
    quiet: bool,
    say,
    sim_seeds: int = 0,
    baselines: bool = False,
) -> tuple[list[tuple[str, float, str]], list[str]]:
    """Train, test, plot and perturb one experiment, and test its first ``sim_seeds``
    seeds in MuJoCo: (timings, report section). ``baselines``: the oracle and DWA take
    the greedy test beside the policies (:func:`references`)."""
    cell = runner.Cell(name, cfg, out / name)
    run_dir = cell.run
    timings = [(f"train {name}", *runner.train(cell, quiet, say))]

    def stage(label: str, note: str, fn):
        t0 = time.perf_counter()
        result = fn()
        timings.append((f"{label} {name}", time.perf_counter() - t0, note(result)))
        return result

    say(f"{name}: testing on {', '.join(cfg.run.test_mazes)}")
    refs = references(baselines)
    tests = f"{cfg.run.test_episodes} episodes x {cfg.n_runs} runs x {len(cfg.run.test_mazes)}"
    labels = [reference_drivers.BASELINES[r].label for r in refs]
    tests += " mazes" + (f", the {' and '.join(labels)} beside them" if refs else "")
    eval_dir = stage("evaluate", lambda _: tests, lambda: runner.test(cell, references=refs))
    say(f"{name}: drawing figures")
    written = stage("plot", lambda w: f"{len(w)} files", lambda: plots.make_plots(run_dir))
    # ROBUSTNESS: the same test under sensor perturbations, on the training maze
    say(f"{name}: testing under sensor perturbations on {cfg.env.maze}")
    rob_dir = stage(
        "robustness",
        lambda _: f"on {cfg.env.maze}",
        lambda: robustness_to_dir(run_dir, out=run_dir / "eval"),
    )
    sec = _section(name, title, cfg, out, written, eval_dir, rob_dir)
    if sim_seeds:
        seeds = [cfg.seed + k for k in range(min(sim_seeds, cfg.seeds))]
        say(f"{name}: testing seeds {seeds[0]}..{seeds[-1]} in MuJoCo physics")
        n = f"{len(seeds)} seeds x {len(cfg.strategies)} strategies x {len(cfg.run.test_mazes)}"
        table = stage("sim2sim", lambda _: f"{n} mazes", lambda: sim_to_sim(run_dir, seeds))
        sec += [_demote(table.read_text()).rstrip(), ""]
    return timings, sec


def references(baselines: bool) -> tuple[str, ...]:
    """The reference drivers a pipeline whose claims are judged between strategies
    tests beside the policies: none, unless ``baselines`` (``--baselines``) asks for the
    oracle and DWA. Their rows judge no claim of the paper and used to cost more than
    the policies' own test."""
    return reference_drivers.names() if baselines else ()


def sim_to_sim(run_dir: Path, seeds: list[int]) -> Path:
    """``jaxnav sim2sim RUN_DIR --seeds ...`` (its own process: only that
    command imports MuJoCo); the path of its markdown table."""
    done = subprocess.run(runner.sim2sim_argv(run_dir, seeds), capture_output=True, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise JaxnavError(f"the sim-to-sim stage failed: {last}")
    return run_dir / "sim2sim" / "sim2sim.md"


def check_mujoco(sim_seeds: int) -> None:
    """Say at once, before any training, if --sim2sim cannot run."""
    if sim_seeds and importlib.util.find_spec("mujoco") is None:
        raise JaxnavError(
            "--sim2sim needs MuJoCo: pip install -e \".[sim]\" (the optional extra 'sim')"
        )


def _section(name, title, cfg, out: Path, written, eval_dir: Path, rob_dir: Path) -> list[str]:
    """The report's section of one experiment: figures, tables, robustness."""
    run_dir = out / name

    def rel(p):
        return Path(p).relative_to(out).as_posix()

    traj = [p for p in written if p.name.startswith("trajectory_")]
    gif = [p for p in written if p.suffix == ".gif"]
    sec = [
        f"## {title}",
        "",
        f"Run directory: `{name}/` (config, metrics.csv, params.npz, eval/, plots/).",
        "",
        "### Training",
        "",
        training_markdown(CsvLog(run_dir / METRICS, ()).read()).rstrip(),
        "",
        f"![training curves]({rel(run_dir / 'plots' / 'training_curves.png')})",
        f"![exploration]({rel(run_dir / 'plots' / 'exploration.png')})",
        "",
        f"### Test episodes (seed {cfg.seed}, first test episode)",
        "",
        " ".join(f"![{p.stem}]({rel(p)})" for p in traj),
        "",
    ]
    if gif:
        sec += [f"![episode animation]({rel(gif[0])})", ""]
    tables = (eval_dir / "tables.md").read_text()
    sec += [_demote(tables).rstrip(), ""]
    rob = (
        (rob_dir / "robustness.md")
        .read_text()
        .replace("](robustness.png)", f"]({rel(rob_dir / 'robustness.png')})")
    )
    return sec + [_demote(rob).rstrip(), ""]


def reproduce(
    out: Path,
    seeds: int,
    episodes: int | None,
    max_steps: int | None,
    test_episodes: int | None,
    quick: bool,
    resume_ok: bool,
    quiet: bool,
    command: str,
    sim_seeds: int = 0,
    baselines: bool = False,
) -> Path:
    """Both experiments end to end into ``out``; ``sim_seeds``: test that many seeds
    of each in MuJoCo too; ``baselines``: test the oracle and DWA beside the policies.
    Returns report.md."""
    sizes = {"--episodes": episodes, "--max-steps": max_steps, "--test-episodes": test_episodes}
    runner.check_request(out, seeds, sizes, resume_ok)
    if sim_seeds < 0:
        raise JaxnavError("--sim2sim must not be negative")
    check_mujoco(sim_seeds)
    cfgs = {
        name: experiment_config(name, seeds, episodes, max_steps, test_episodes)
        for name, _ in EXPERIMENTS
    }
    out.mkdir(parents=True, exist_ok=True)

    say = runner.sayer("reproduce", quiet)
    info = runner.machine_info()
    timings: list[tuple[str, float, str]] = []
    sections: list[str] = []
    for name, title in EXPERIMENTS:
        t, sec = _experiment(name, title, cfgs[name], out, quiet, say, sim_seeds, baselines)
        timings += t
        sections += sec
    t0 = time.perf_counter()
    claims = claims_markdown(evaluate_claims(experiment_files(out)), quick=quick)
    atomic_write_text(out / "claims.md", claims)
    timings.append(("claims", time.perf_counter() - t0, "verdicts from the files above"))
    first = cfgs[EXPERIMENTS[0][0]]
    settings = {
        "command": command,
        "seeds": seeds,
        "episodes": first.episodes,
        "max_steps": first.env.max_steps,
        "test_episodes": first.run.test_episodes,
        "quick": quick,
    }
    return write_report(out, info, settings, timings, sections, claims)


def experiment_files(
    out: Path, names: list[str] | None = None
) -> dict[str, tuple[list[dict[str, str]], str]]:
    """name -> (metrics.csv rows, eval/results.csv text) of each experiment in ``out``
    (of ``names`` only, if given)."""
    files = {}
    for name in names if names is not None else [n for n, _ in EXPERIMENTS]:
        run_dir = out / name
        rows = CsvLog(run_dir / METRICS, ()).read()
        files[name] = (rows, (run_dir / "eval" / "results.csv").read_text())
    return files


# The data behind a reproduction's claims and tables, per experiment (publish_report).
REPORT_DATA = (
    "config.yaml",
    "summary.json",
    "metrics.csv",
    "eval/results.csv",
    "eval/robustness.csv",
)


def publish_report(src: Path, dst: Path) -> list[str]:
    """Copy a finished reproduction in ``src`` to ``dst`` (``docs/report``), replacing
    it: report.md, claims.md, every file report.md shows, and each experiment's data
    behind the claims and tables (:data:`REPORT_DATA`). The files copied, relative."""
    import re
    import shutil

    if not (src / "report.md").is_file():
        raise JaxnavError(f"reproduce --publish: {src} holds no finished reproduction (report.md)")
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", (src / "report.md").read_text())
    experiments = sorted({Path(link).parts[0] for link in links if "/" in link})
    files = ["report.md", "claims.md", *links]
    files += [f"{e}/{name}" for e in experiments for name in REPORT_DATA]
    missing = [f for f in files if not (src / f).is_file()]
    if missing:
        raise JaxnavError(f"reproduce --publish: {src} has no {missing[0]}")
    if dst.exists():
        shutil.rmtree(dst)
    for name in files:
        (dst / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(src / name, dst / name)
    return files
