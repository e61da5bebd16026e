"""The ``jaxnav`` console command, ``jaxnav list`` and the shipped configs."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from jaxnav.__main__ import COMMANDS
from jaxnav.__main__ import main as jaxnav_main
from jaxnav.commands.list import catalog, settings_markdown
from jaxnav.core import agents
from jaxnav.core.config import FIELD_TYPES, SETTINGS, SWEEPABLE, load_config
from jaxnav.core.shipped import builtin_configs
from jaxnav.world.maps import BUILTIN_MAZES, make_maze

ROOT = Path(__file__).resolve().parents[1]


def test_the_top_level_holds_env_the_agents_and_the_main_command_only():
    """The package's top level is the task, the agents and ``python -m jaxnav.train``;
    every command is a module of ``jaxnav.commands`` and ``jaxnav`` lists each one."""
    modules = {p.stem for p in (ROOT / "jaxnav").glob("*.py")}
    assert modules == {"__init__", "__main__", "dqn", "pqn", "train"}
    assert (ROOT / "jaxnav" / "env" / "__init__.py").is_file()  # the task, a package
    commands = {p.stem for p in (ROOT / "jaxnav" / "commands").glob("*.py")}
    assert commands - {"__init__"} == set(COMMANDS)


def test_help_lists_every_command_with_one_line(capsys):
    assert jaxnav_main(["--help"]) == 0
    out = capsys.readouterr().out
    for name, (what, _) in COMMANDS.items():
        assert f"  {name}" in out and what in out


@pytest.mark.slow  # 5 s on 2 cores
@pytest.mark.parametrize("how", ["jaxnav", "python -m jaxnav", "python -m jaxnav.train"])
def test_a_commands_help_and_errors_name_it_as_the_user_ran_it(how, tmp_path):
    """``python -m jaxnav train --help`` said ``usage: jaxnav train``."""
    if how == "jaxnav":  # the console script, as pip writes it
        script = tmp_path / "jaxnav"
        script.write_text("import sys\nfrom jaxnav.__main__ import main\nsys.exit(main())\n")
        cmd = [sys.executable, str(script), "train"]
    elif how == "python -m jaxnav":
        cmd = [sys.executable, "-m", "jaxnav", "train"]
    else:
        cmd = [sys.executable, "-m", "jaxnav.train"]
    shown = "jaxnav train" if how == "jaxnav" else "python -m jaxnav train"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    run = lambda *a: subprocess.run([*cmd, *a], cwd=tmp_path, env=env, capture_output=True)
    helped = run("--help")
    assert helped.returncode == 0 and helped.stdout.decode().startswith(f"usage: {shown} ")
    refused = run("smoke", "sed=1")
    assert refused.returncode == 2
    name = shown.removeprefix("python -m ")
    assert refused.stderr.decode() == (
        f"{name}: error: config: unknown key 'sed' (did you mean 'seed'?)\n"
    )


def test_unknown_command_is_one_line_and_exit_2(capsys):
    assert jaxnav_main(["trian"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxnav: error: unknown command 'trian'")


def test_list_shows_mazes_configs_and_every_setting_with_its_sweep_mark():
    text = catalog()
    for name, what in BUILTIN_MAZES.items():
        assert f"  {name}" in text and what in text
    configs = builtin_configs()
    assert {"smoke", "paper_no_obstacles", "paper_obstacles"} <= set(configs)
    for name in configs:
        assert f"  {name}  " in text
    agent_lines = text.split("agents (agent=...):\n")[1].split("\n\n")[0].splitlines()
    assert [ln.split()[0] for ln in agent_lines] == list(agents.names())
    settings = text.split("settings (")[1].splitlines()[1:-1]
    rows = {ln[4:].split()[0]: ln for ln in settings}
    for key in FIELD_TYPES:
        assert key in rows, key
        assert rows[key].startswith("  *") == (key in SWEEPABLE), key


def test_builtin_config_names_and_configs_paths_work_from_any_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    by_name = load_config("smoke")
    assert by_name == load_config("configs/smoke.yaml") == load_config("smoke.yaml")
    assert by_name.seeds == 2 and by_name.episodes == 40
    shipped = make_maze(str(ROOT / "configs" / "mazes" / "corridor.yaml"))
    maze = make_maze("configs/mazes/corridor.yaml")
    assert (maze.segments == shipped.segments).all() and (maze.start == shipped.start).all()


@pytest.mark.slow
def test_a_wheel_runs_the_quick_start_from_an_empty_folder(tmp_path):
    """Built from the repository and installed elsewhere, the package finds its configs."""
    wheels, site, empty = tmp_path / "wheels", tmp_path / "site", tmp_path / "empty"
    empty.mkdir()
    # A copy of the sources: building in the checkout would leave build/ there, whose
    # stale modules a later wheel could pick up.
    src = tmp_path / "src"
    skip = (".venv*", ".git", "build", "runs", "*.egg-info", "__pycache__", ".*cache", ".hyp*")
    shutil.copytree(ROOT, src, symlinks=True, ignore=shutil.ignore_patterns(*skip))
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    subprocess.run([*pip, "wheel", "--no-deps", "-w", wheels, src], check=True, timeout=300)
    (wheel,) = wheels.glob("jaxnav-*.whl")
    subprocess.run([*pip, "install", "--no-deps", "--target", site, wheel], check=True)
    assert (site / "jaxnav" / "configs" / "smoke.yaml").is_file()
    assert (site / "jaxnav" / "configs" / "studies" / "when_ebe_helps.yaml").is_file()
    # what `jaxnav drive` plays without training, and the worlds it names
    assert (site / "jaxnav" / "policies" / "drive_anywhere.npz").is_file()
    assert (site / "jaxnav" / "policies" / "drive_anywhere.md").is_file()
    assert (site / "jaxnav" / "configs" / "mazes" / "heldout" / "office.yaml").is_file()
    assert (site / "jaxnav" / "configs" / "barn" / "barn.npz").is_file()
    env = {**os.environ, "PYTHONPATH": str(site)}
    for config in ("smoke", "configs/smoke.yaml"):
        out = empty / config.replace("/", "_")
        run = subprocess.run(
            [
                sys.executable,
                "-m",
                "jaxnav",
                "train",
                config,
                "seeds=1",
                "episodes=2",
                "env.max_steps=20",
                "dqn.batch_size=16",
                "--out",
                out,
            ],
            cwd=empty,
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert run.returncode == 0, run.stderr
        assert (out / "metrics.csv").is_file()


def test_the_settings_page_is_generated_from_the_declarations():
    page = (ROOT / "docs" / "settings.md").read_text()
    assert page == settings_markdown(), "regenerate: jaxnav list --markdown > docs/settings.md"
    for key, s in SETTINGS.items():
        assert f"| `{key}` |" in page and s.help in page


def test_the_architecture_page_has_a_line_for_every_module():
    """docs/architecture.md's "One line per module" names every module of the package
    under its subpackage's heading (commands and the top modules under "On top")."""
    import re

    text = (ROOT / "docs" / "architecture.md").read_text().split("## One line per module")[1]
    named: dict[str, set[str]] = {}
    section = "top"
    for line in text.splitlines():
        heading = re.match(r"\*\*(\w+)/\*\*", line)
        if heading or line.startswith("**On top**"):
            section = heading.group(1) if heading else "top"
        elif line.startswith("- "):
            named.setdefault(section, set()).update(re.findall(r"`(\w+)`", line))
    package = ROOT / "jaxnav"
    missing = []
    for path in sorted(package.rglob("*.py")):
        rel = path.relative_to(package)
        section = "top" if len(rel.parts) == 1 else rel.parts[0]
        if path.stem != "__init__" and path.stem not in named.get(section, set()):
            missing.append(str(rel))
    assert not missing, f"modules without a line in docs/architecture.md: {missing}"


def test_the_house_keeps_its_shape():
    """No module of the package over 600 lines (split it along its seams), and scripts/
    holds only the environments' installers: experiment programs are commands, study
    kinds or package functions with tests, or benchmarks under bench/."""
    long = {
        str(p.relative_to(ROOT)): n
        for p in (ROOT / "jaxnav").rglob("*.py")
        if (n := len(p.read_text().splitlines())) > 600
    }
    assert not long, f"modules over 600 lines: {long}"
    assert not list((ROOT / "scripts").rglob("*.py")), "Python programs in scripts/"
