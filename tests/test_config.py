"""Configs: numbers as people write them, non-finite numbers refused, the preset table."""

import pytest

from jaxnav.core.config import ConfigError, load_config
from jaxnav.core.settings import PRESETS


@pytest.mark.parametrize(
    "override, field, value",
    [
        ("dqn.lr=1e-4", ("dqn", "lr"), 1e-4),  # YAML 1.1 reads 1e-4 as a string
        ("dqn.lr=2.5E-4", ("dqn", "lr"), 2.5e-4),
        ("exploration.eps_decay=9.9e-1", ("exploration", "eps_decay"), 0.99),
        ("dqn.buffer_size=1_000_000", ("dqn", "buffer_size"), 1_000_000),
        ("episodes=5E2", (None, "episodes"), 500),
        ("env.lidar_noise_std=1e-2", ("env", "lidar_noise_std"), 0.01),
        ("env.odom_noise=[1e-2, 2E-2]", ("env", "odom_noise"), (0.01, 0.02)),
    ],
)
def test_numbers_as_people_write_them(override, field, value):
    cfg = load_config(None, [override])
    section, name = field
    got = getattr(cfg if section is None else getattr(cfg, section), name)
    assert got == pytest.approx(value) and type(got) is type(value)


def test_numbers_in_a_yaml_file_too(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("dqn:\n  lr: 1e-4\n  buffer_size: 1_000_000\nepisodes: 1E2\n")
    cfg = load_config(str(path))
    assert (cfg.dqn.lr, cfg.dqn.buffer_size, cfg.episodes) == (1e-4, 1_000_000, 100)


@pytest.mark.parametrize(
    "override, message",
    [
        ("dqn.lr=.inf", "dqn.lr must be a finite number"),
        ("dqn.gamma=.nan", "dqn.gamma must be a finite number"),
        ("env.odom_noise=[.nan, 0]", "env.odom_noise must be a finite number"),
        ("episodes=2.5", "episodes must be an integer"),
        ("seeds=1e0_0", "seeds must be an integer"),
        ("dqn.lr=1e-4x", "dqn.lr must be a number"),
        ("seeds=true", "seeds must be an integer"),
    ],
)
def test_bad_numbers_are_refused_with_the_field_named(override, message):
    with pytest.raises(ConfigError, match=message):
        load_config(None, [override])


def test_a_preset_sets_the_training_constants_of_one_table():
    cfg = load_config(None, ["preset=robotis"])
    robotis = PRESETS["robotis"]
    assert (cfg.episodes, cfg.dqn.gamma, cfg.dqn.target_update) == (
        robotis.episodes,
        robotis.gamma,
        robotis.target_update,
    )
    paper = load_config(None)
    assert (paper.episodes, paper.dqn.gamma) == (PRESETS["paper"].episodes, PRESETS["paper"].gamma)


def test_a_batch_larger_than_the_replay_memory_is_refused():
    # smoke: 40 episodes of 200 steps, so a run's replay memory holds 8000 transitions
    with pytest.raises(ConfigError, match=r"dqn.batch_size \(8001\) is larger than the replay"):
        load_config("smoke", ["dqn.batch_size=8001"])
    assert load_config("smoke", ["dqn.batch_size=8000"]).dqn.batch_size == 8000


@pytest.mark.parametrize(
    "overrides",
    [[], ["env.maze=square4_obstacles", "env.n_beams=360"], ["dqn.prioritised=true"]],
)
def test_memory_estimate_bounds_the_replay_buffers_within_ten_percent(overrides):
    from jaxnav.agent.replay import nbytes
    from jaxnav.env import from_config

    cfg = load_config("smoke", ["seeds=3", *overrides])
    env, params = from_config(cfg)
    size = (cfg.buffer_capacity, env.obs_size, int(params.max_steps), cfg.dqn.prioritised)
    real = cfg.n_runs * nbytes(*size)
    assert real <= cfg.memory_estimate() <= 1.1 * real


def test_a_run_too_big_for_the_machine_says_so_before_allocating(monkeypatch):
    from jaxnav.core import cli
    from jaxnav.core.errors import JaxnavError

    gib = 2**30
    cfg = load_config("smoke", ["seeds=100000"])  # about 180 GiB of replay memory
    with pytest.raises(JaxnavError, match=r"needs about 1\d\d\.\d GiB .*more than this machine"):
        cli.confirm_memory(cfg.memory_estimate(), yes=True, memory=24 * gib)
    monkeypatch.setattr("sys.stdin", None)  # not a terminal: refused with the estimate
    with pytest.raises(JaxnavError, match="over half of this machine's 24.0 GiB: --yes starts"):
        cli.confirm_memory(15 * gib, yes=False, memory=24 * gib)
    cli.confirm_memory(15 * gib, yes=True, memory=24 * gib)  # --yes: goes on
    cli.confirm_memory(11 * gib, yes=False, memory=24 * gib)  # under half: no question


def test_the_memory_question_takes_yes_at_a_terminal(monkeypatch):
    from jaxnav.core import cli
    from jaxnav.core.errors import JaxnavError

    class Tty:
        def isatty(self):
            return True

    monkeypatch.setattr("sys.stdin", Tty())
    gib = 2**30
    cli.confirm_memory(15 * gib, yes=False, memory=24 * gib, ask=lambda _: "y")
    with pytest.raises(JaxnavError, match="not started"):
        cli.confirm_memory(15 * gib, yes=False, memory=24 * gib, ask=lambda _: "")


def test_an_agent_switch_names_every_setting_it_needs_in_one_line():
    """``smoke agent=sac`` was refused one setting at a time (the actions, then the
    reward, then the strategies); one line now names them all, and adding them loads."""
    with pytest.raises(ConfigError) as e:
        load_config("smoke", ["agent=sac"])
    line = str(e.value)
    need = ["env.actions=continuous", "env.reward=progress", "strategies=[policy]"]
    assert "\n" not in line and all(n in line for n in need), line
    assert "drive_sac_obstacles" in line  # a shipped config of that agent
    cfg = load_config("smoke", ["agent=sac", *need])
    assert cfg.agent == "sac" and cfg.env.actions == "continuous"
    # and back: a continuous config switched to a discrete agent
    with pytest.raises(ConfigError, match=r"agent pqn .*env.actions=vw strategies=\[ebe"):
        load_config("drive_sac_obstacles", ["agent=pqn"])


@pytest.mark.parametrize(
    "text, line",
    [
        ("seeds: 2\nepisodes 40\nenv:\n  maze: square4\n", 2),  # a key without its colon
        ("seeds: 2\nstrategies: [ebe, epsilon_greedy\nepisodes: 3\n", 2),  # an open bracket
        ('seeds: 2\nenv:\n  maze: "square4\nepisodes: 3\n', 3),  # an open quote
    ],
)
def test_malformed_yaml_names_the_line_the_mistake_is_on(tmp_path, text, line):
    """PyYAML notices these a line after the mistake; the line it was reading is named."""
    path = tmp_path / "c.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=rf"at line {line}\b"):
        load_config(str(path))


@pytest.mark.parametrize(
    "overrides, says",
    [
        # a maze family's settings without that family drawn
        (["env.grid_rows=6"], r"env.grid_rows \(6\) is a setting of grid mazes, .* default \(4\)"),
        (["env.cyl_count=3"], "env.cyl_count .* is a setting of cylinders mazes"),
        (
            ["drive_anywhere", "env.mix_worlds=[rooms, stage4]", "env.mix_weights=[]"],
            r"env.grid_rows \(3\) .* \(env.generator mix of rooms, stage4\): .* \(4\)",
        ),
        (["env.generator=grid", "env.rooms_door=0.9"], "env.rooms_door .* of rooms mazes"),
        (["env.min_path_cells=2"], "env.min_path_cells .* of grid or rooms mazes"),
        (["env.mix_weights=[1]"], r"env.mix_weights \(\[1\]\) is a setting of mix mazes"),
        # a drawn maze's settings with a fixed maze
        (["env.new_maze_every=3"], "env.new_maze_every is a drawn mazes' setting"),
        (["env.split=test"], "env.split is a drawn mazes' setting"),
        # a progress reward's terms with another reward, a distance without its penalty
        (["env.step_penalty=0.02"], "env.step_penalty is a term of the progress reward"),
        (["preset=modern", "env.reward=sparse", "env.progress_scale=3"], "with env.reward sparse"),
        (
            ["preset=modern", "env.proximity_penalty=0", "env.proximity_distance=0.5"],
            "it needs env.proximity_penalty > 0",
        ),
    ],
)
def test_a_setting_that_nothing_reads_is_refused_in_one_line(overrides, says):
    config = overrides[0] if "=" not in overrides[0] else None
    with pytest.raises(ConfigError, match=says):
        load_config(config, overrides[1:] if config else overrides)


@pytest.mark.parametrize(
    "overrides",
    [
        ["env.generator=rooms", "env.min_path_cells=2"],  # rooms read it too
        ["env.generator=grid", "env.maze_bank=64", "env.split=test", "env.new_maze_every=2"],
        [
            "env.generator=mix",
            "env.mix_worlds=[grid,cylinders]",
            "env.maze_bank=64",
            "env.grid_rows=3",
            "env.cyl_count=4",
        ],
        ["preset=modern", "env.reward=dense"],  # the preset's own progress terms stay
        ["preset=modern", "env.step_penalty=0.02", "env.proximity_distance=0.4"],
        ["robot=jackal"],  # the robot's defaults are not the user's settings
    ],
)
def test_settings_that_are_read_are_accepted(overrides):
    load_config(None, overrides)
