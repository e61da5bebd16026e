"""The config's sections: every environment, exploration and run setting (the agents'
sections, DQN's, PQN's and SAC's, are :mod:`jaxnav.core.agent_sections`),
declared once each with :func:`jaxnav.core.settings.setting` (default, a line of help,
its rule, whether a sweep may vary it). :mod:`jaxnav.core.config` assembles them into
:class:`~jaxnav.core.config.Config` and derives validation, sweeps and listings. The
drawn-maze families' own settings are declared with their family
(:mod:`jaxnav.core.families`) and laid out in :class:`EnvConfig` after ``generator``.
"""

from __future__ import annotations

from dataclasses import dataclass

from jaxnav.core import families, robots
from jaxnav.core.settings import (
    ACTION_KINDS,
    AT_LEAST_1,
    BURGER_MAX_OMEGA,
    BURGER_MAX_V,
    MARGIN,
    NON_NEGATIVE,
    OWN_PACE,
    PACE_RANGE,
    PAIR_NON_NEGATIVE,
    POSITIVE,
    SCALE_RANGE,
    UNIT,
    UNIT_OPEN,
    one_of,
    setting,
)


@dataclass(frozen=True)
@families.settings_after("generator")
class EnvConfig:
    maze: str = setting(
        "square4",
        "built-in maze name, a maze YAML file, a ROS map_server map's YAML file or a "
        "world of a source (barn:0, ...)",
    )
    robot: str = setting(
        "burger",
        "the robot (also the top-level key robot): its footprint, speed limits and LiDAR "
        "become the defaults of env.robot_radius, env.n_beams, env.lidar_fov, "
        "env.min_range, env.max_range, env.speed_range, env.max_yaw_rate, and scale the "
        "action sets (jaxnav list)",
        rule=(
            lambda v: v in robots.names(),
            lambda: "must be one of " + ", ".join(robots.names()),
        ),
    )
    robot_radius: float = setting(
        0.13, "the robot's disc for collisions, m (burger: ROBOTIS' 0.13)", rule=POSITIVE
    )
    n_beams: int = setting(24, "LiDAR beams (360 on the robot)", rule=AT_LEAST_1)
    lidar_fov: float = setting(
        360.0,
        "the LiDAR's field of view, degrees: 360 (beam 0 ahead, counter-clockwise) or less "
        "(the beams spread from the right edge to the left edge, both included)",
        rule=(lambda v: 0.0 < v <= 360.0, "must be in (0, 360]"),
    )
    min_range: float = setting(0.12, "the LiDAR's shortest reading, m", rule=NON_NEGATIVE)
    max_range: float = setting(3.5, "the LiDAR's longest reading, m", rule=POSITIVE)
    goal_radius: float = setting(0.2, "a goal is reached within this distance, m", rule=POSITIVE)
    goal_ends: bool = setting(
        False,
        "reaching the goal ends the episode (BARN's protocol: one attempt per episode, "
        "the next starting again from the start pose)",
    )
    max_steps: int = setting(500, "an episode is truncated after this many steps", rule=AT_LEAST_1)
    attempt_limit: int = setting(
        0,
        "steps one goal attempt may take before it counts as a time-out in the navigation "
        "metrics (0: the episode's step limit, env.max_steps); the dynamics do not change",
        rule=NON_NEGATIVE,
    )
    maze_bank_refresh: int = setting(
        0,
        "drawn mazes with a bank: a training run draws a new bank each time its env steps "
        "(all its environments together) pass a multiple of this (0: one bank all run)",
        rule=NON_NEGATIVE,
    )
    lidar_noise_std: float = setting(
        0.0, "std of Gaussian range noise, m (0.01: Gazebo's)", rule=NON_NEGATIVE, sweep=True
    )
    R_plus: float | None = setting(None, "reward for a goal (null: the preset's)", sweep=True)
    R_minus: float | None = setting(None, "reward for a collision (null: the preset's)", sweep=True)
    reward_span: float | None = setting(
        None, "the heading term's phi_a spans +-this, rad (null: the preset's)", sweep=True
    )
    reward_distance_exp: bool | None = setting(
        None, "D = 2^(d_c / d_0) (ROBOTIS) instead of d_c (null: the preset's)"
    )
    obstacle_obs: bool | None = setting(
        None, "observe the smallest range and its beam (null: on for mazes with obstacles)"
    )
    # Realism for a real robot, all off in the paper (see jaxnav.env.NavEnv):
    beam_dropout: float = setting(
        0.0, "probability a beam returns nothing (reads max range)", rule=UNIT_OPEN
    )
    odom_noise: tuple[float, ...] = setting(
        (0.0, 0.0), "std of (position m, yaw rad) odometry noise", rule=PAIR_NON_NEGATIVE
    )
    random_start: bool = setting(False, "each episode starts at a random free pose")
    restart_goal: str = setting(
        "keep",
        "the goal after a collision or the step limit: keep (ROBOTIS': the restart retries "
        "the goal, so a deterministic policy in a fixed world replays the same attempt) or new "
        "(drawn as a reset draws it)",
        rule=one_of("keep", "new"),
    )
    maze_scale: tuple[float, ...] = setting(
        (1.0, 1.0), "per-episode maze scale drawn from [low, high]", rule=SCALE_RANGE
    )
    motion_pace: tuple[float, ...] = setting(
        OWN_PACE,
        "training: each episode runs the moving cylinders at a pace drawn from [low, high] "
        "times their own (0: standing still), the same loops; a run's test plays them at "
        "their own pace",
        rule=PACE_RANGE,
    )
    pace_curriculum: float = setting(
        0.0,
        "training: the range env.motion_pace draws from moves in a straight line to the "
        "cylinders' own pace [1, 1] over this share of the budget of env steps, and stays "
        "there (a curriculum: slow paces first); 0 is off",
        rule=UNIT,
    )
    collision_margin: float = setting(
        0.0,
        "training: an episode also ends as a collision when the robot's edge comes within "
        "this many metres of a surface (a padded footprint); a run's test counts real "
        "collisions",
        rule=MARGIN,
    )
    wheel_limit: bool = setting(
        False, "drive each action as the burger's firmware clips it (wheels at most 0.21 m/s)"
    )
    # ROBOTIS-faithful switches, all off by default (see jaxnav.env.NavEnv):
    collision: str = setting(
        "disc",
        "disc (exact) or lidar (ROBOTIS: smallest beam below 0.13 m)",
        rule=one_of("disc", "lidar"),
    )
    goal_sampler: str = setting(
        "free",
        "free, or robotis (respawnGoal.py's grid, boxes and rules)",
        rule=one_of("free", "robotis"),
    )
    beam_layout: str = setting(
        "even",
        "even, or gazebo (n beams over [0, 2 pi] inclusive)",
        rule=one_of("even", "gazebo"),
    )
    action_delay: bool = setting(False, "each action applied one step late (ROBOTIS' loop)")
    broad_phase: str = setting(
        "auto",
        "LiDAR: auto (drawn grid mazes walk their lattice, unless scaled), lattice (walk "
        "it, refused where it cannot), or none (every beam tests every wall)",
        rule=one_of("auto", "lattice", "none"),
    )
    # Procedural mazes, off by default: env.maze is the maze. Each family's own settings
    # (grid_*, cyl_*, rooms_*, ...) follow this one, declared with the family in
    # jaxnav.core.families.
    generator: str = setting(
        "",
        f"empty: the fixed maze env.maze; {families.listing(families.names())}: a random maze "
        "of that family, new every new_maze_every episodes",
        rule=families.GENERATOR_RULE,
    )
    new_maze_every: int = setting(1, "drawn mazes: episodes in each maze", rule=AT_LEAST_1)
    maze_bank: int = setting(
        0,
        "drawn mazes: layouts (maze, start and goal) each training run draws ahead from its "
        "own key and picks from at random when it needs a new one (0: each layout drawn when "
        "needed); tests draw as before",
        rule=NON_NEGATIVE,
    )
    split: str = setting(
        "train",
        "drawn mazes: train or test mazes (a layout is in one split only)",
        rule=one_of("train", "test"),
    )
    reward: str = setting(
        "dense",
        "dense (the paper's heading shaping), sparse (goal and collision only), geodesic "
        "(grid, rooms: the shaping follows the shortest path through the maze) or progress "
        "(env.progress_scale per metre the robot comes closer to its goal)",
        rule=one_of("dense", "sparse", "geodesic", "progress"),
    )
    progress_scale: float = setting(
        10.0, "progress reward: reward per metre closer to the goal", rule=NON_NEGATIVE
    )
    progress_path: str = setting(
        "straight",
        "progress reward: closer along the straight line to the goal, or (geodesic, grid "
        "and rooms mazes) along the shortest path through the maze, so no dead end pays",
        rule=one_of("straight", "geodesic"),
    )
    step_penalty: float = setting(
        0.0,
        "progress reward: taken from every step that neither reaches nor collides",
        rule=NON_NEGATIVE,
    )
    proximity_penalty: float = setting(
        0.0,
        "progress reward: taken, times 1 - clearance / env.proximity_distance, where the "
        "robot's path comes within env.proximity_distance of a surface (clearance beyond "
        "its radius)",
        rule=NON_NEGATIVE,
    )
    change_penalty: float = setting(
        0.0,
        "progress reward: taken times the change of the driven command from the last "
        "step's, |dv| / 0.22 m/s + |d omega| / 2.84 rad/s (needs env.observation normalised, "
        "which holds the last command): smoother driving",
        rule=NON_NEGATIVE,
    )
    proximity_distance: float = setting(
        0.3,
        "progress reward: the clearance below which the proximity penalty applies, m",
        rule=POSITIVE,
    )
    moving_proximity_penalty: float = setting(
        0.0,
        "progress reward, mazes with moving cylinders: taken, times 1 - clearance / "
        "env.moving_proximity_distance, where the step brings the robot within "
        "env.moving_proximity_distance of a moving cylinder (clearance beyond its radius), "
        "beside env.proximity_penalty",
        rule=NON_NEGATIVE,
    )
    moving_proximity_distance: float = setting(
        0.5,
        "progress reward: the clearance to a moving cylinder below which "
        "env.moving_proximity_penalty applies, m",
        rule=POSITIVE,
    )
    actions: str = setting(
        "paper",
        "paper (5 yaw rates at 0.15 m/s), paper_stop (those and a stop), vw (speeds 0, "
        "0.11 and 0.22 m/s by the 5 yaw rates), vw_reverse (those and -0.11 m/s, backing "
        "up): the commands the agent picks from; or "
        "continuous: (speed, yaw rate) within env.speed_range and env.max_yaw_rate (SAC)",
        rule=one_of(*ACTION_KINDS),
    )
    speed_range: tuple[float, ...] = setting(
        (0.0, BURGER_MAX_V),
        "continuous actions: [lowest, highest] forward speed, m/s",
        rule=(
            lambda x: len(x) == 2 and 0.0 <= x[0] <= x[1] and x[1] > 0.0,
            "must be [low, high] with 0 <= low <= high and high > 0",
        ),
    )
    max_yaw_rate: float = setting(
        BURGER_MAX_OMEGA,
        "continuous actions: the largest yaw rate either way, rad/s",
        rule=POSITIVE,
    )
    beyond_limits: bool = setting(
        False,
        "continuous actions: allow env.speed_range and env.max_yaw_rate beyond the burger's "
        "0.22 m/s and 2.84 rad/s",
    )
    top_speed: float | None = setting(
        None,
        "action sets (paper_stop, vw, vw_reverse): the set's top forward speed, m/s, its "
        "other speeds scaled alike (null: the robot's, as the set scales with it); at most "
        "the robot's",
        rule=(lambda x: x is None or x > 0.0, "must be null or above 0"),
    )
    scan_beams: int = setting(
        0,
        "0, or beams cast (a multiple of env.n_beams): each observed beam is the least "
        "range of its sector of them, so thin obstacles between observed beams are seen",
        rule=NON_NEGATIVE,
    )
    scan_history: int = setting(
        0,
        "normalised observation: the scans of the last k steps follow this one's (newest "
        "first), so the policy can see what moves",
        rule=NON_NEGATIVE,
    )
    history_changes: bool = setting(
        False,
        "with env.scan_history: observe each beam's change since each earlier scan (x10, "
        "clipped to [-1, 1]) instead of the earlier scans",
    )
    history_turned: bool = setting(
        False,
        "with env.history_changes: each earlier scan is seen from the heading now (turned "
        "by the yaw since it, from odometry) before the changes are taken, so turning in "
        "place does not read as motion and what changes is what moves",
    )
    observe_moving: int = setting(
        0,
        "normalised observation: also the k nearest moving cylinders' position and "
        "velocity in the robot's frame, as the simulator knows them (no sensor on the "
        "robot gives them: a diagnosis of what the scan leaves out; export refuses it)",
        rule=NON_NEGATIVE,
    )
    observe_command: bool = setting(
        True,
        "normalised observation: it holds the last command driven (v, omega); false: two "
        "zeros in its place, the layout kept (what the command is worth, measured)",
    )
    waypoint: bool = setting(
        False,
        "normalised observation: also the heading and distance to where the shortest path "
        "through the maze heads next (the next opening on it, or the goal), as a global "
        "planner's path guides a local controller (grid, rooms; a fixed test maze: the goal)",
    )
    observation: str = setting(
        "robotis",
        "robotis (ranges, heading, distance in m and rad, raw) or normalised (ranges and "
        "distance over the sensor's range, heading over pi, and the last command over the "
        "burger's limits)",
        rule=one_of("robotis", "normalised"),
    )


@dataclass(frozen=True)
class ExplorationConfig:
    ebe_temperature: float = setting(
        1.0, "softmax temperature of EBE (1 in the paper)", rule=POSITIVE, sweep=True
    )
    ebe_power: float = setting(
        1.0,
        "EBE explores with probability H(s)^power (1 in the paper)",
        rule=POSITIVE,
        sweep=True,
    )
    boltzmann_temperature: float = setting(
        1.0, "Boltzmann samples from softmax(Q / T)", rule=POSITIVE, sweep=True
    )
    eps_start: float = setting(1.0, "epsilon of the first episode", rule=UNIT, sweep=True)
    eps_decay: float = setting(0.99, "epsilon's factor per episode", rule=UNIT, sweep=True)
    eps_min: float = setting(0.05, "epsilon's floor", rule=UNIT, sweep=True)
    # The field's exploration methods (strategies rnd, noisy, count), each read only by
    # its own strategy's runs:
    rnd_scale: float = setting(
        0.1,
        "rnd: the intrinsic reward's weight beside the environment's (the predictor's error, "
        "over the running std of its discounted sum)",
        rule=NON_NEGATIVE,
        sweep=True,
    )
    noisy_sigma: float = setting(
        0.5,
        "noisy: sigma_0 of the factorised noise; each noisy layer's sigmas start at "
        "sigma_0 / sqrt(its inputs) (Fortunato et al. 2018)",
        rule=POSITIVE,
    )
    count_scale: float = setting(
        0.1,
        "count: the bonus is count_scale / sqrt(visits) of the cell the robot reaches",
        rule=NON_NEGATIVE,
        sweep=True,
    )
    count_cell: float = setting(
        0.5, "count: the side of a cell of the position grid counted, m", rule=POSITIVE
    )


@dataclass(frozen=True)
class RunConfig:
    chunk_steps: int = setting(
        10_000,
        "the most env steps per run of one compiled chunk (the host cuts chunks shorter "
        "to run.chunk_s; the numbers are the same wherever chunks end)",
        rule=AT_LEAST_1,
    )
    chunk_s: float = setting(
        10.0,
        "seconds of training the host aims each chunk at, so the progress and logs move "
        "(0: every chunk run.chunk_steps long)",
        rule=NON_NEGATIVE,
    )
    checkpoint_s: float = setting(
        30.0,
        "seconds of training between checkpoints, whatever the budget (Ctrl-C or a kill "
        "loses at most this much; 0: after every chunk)",
        rule=NON_NEGATIVE,
    )
    test_mazes: tuple[str, ...] = setting(
        ("square4", "square8", "square2", "triangle", "pentagon"), "mazes of the test"
    )
    test_episodes: int = setting(10, "consecutive test episodes per maze", rule=AT_LEAST_1)
    dwa: str = setting(
        "jaxnav",
        "the DWA reference driver's parameters: jaxnav (its own, over the action set) or "
        "barn (the BARN challenge's base_local_planner_params.yaml: its velocity samples, "
        "2 s of forward simulation, its padded footprint; jaxnav evaluate --baseline dwa) "
        "or barn_map (those, under a global planner that knows the map)",
        rule=one_of("jaxnav", "barn", "barn_map"),
    )
    on_divergence: str = setting(
        "stop",
        "a run whose numbers stop being finite: stop the command, or drop that run",
        rule=one_of("stop", "drop"),
    )
    tensorboard: bool = setting(
        False, "training curves for TensorBoard in RUN_DIR/tensorboard (extra 'tensorboard')"
    )
    eval_every: int = setting(
        0,
        "env steps per run between greedy evaluations of every run, to eval.csv (0: none)",
        rule=NON_NEGATIVE,
    )
    eval_episodes: int = setting(
        5, "consecutive episodes of each greedy evaluation (run.eval_every)", rule=AT_LEAST_1
    )
    init_from: str = setting(
        "",
        "a finished run whose policies these runs start from (its params.npz: the same "
        "strategy and seed, else the same seed; the same network); empty: fresh",
    )
    coverage: bool = setting(
        False,
        "record where each run's robot has been while it trains and the env step of its "
        "first goal: eval.csv's coverage (the share of the world's free cells visited, on "
        "the oracle's raster pooled into 0.25 m cells) and first_goal (needs "
        "run.eval_every, agent pqn and a fixed maze)",
    )
    keep_best: bool = setting(
        False,
        "params.npz keeps each run's policy at its best greedy evaluation on held-out "
        "episodes (run.eval_every), not its last",
    )
