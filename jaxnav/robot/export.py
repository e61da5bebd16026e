"""``jaxnav export RUN_DIR [--strategy ebe] [--seed K] [--out policy.npz]``

Exports one trained Q-network of a run to a portable policy file (plain NumPy
arrays, no pickle) with everything needed to feed it on a robot: the observation
layout, the actions, the training maze. :mod:`jaxnav.robot.deploy` reads and runs it
without JAX.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from jaxnav import __version__
from jaxnav.core import rundir
from jaxnav.core import strategies as registry
from jaxnav.core.config import dump_config, load_config
from jaxnav.core.errors import PolicyError
from jaxnav.core.settings import BURGER_MAX_OMEGA, BURGER_MAX_V
from jaxnav.env import from_config
from jaxnav.robot.deploy import (
    COMMAND_VERSION,
    CONTINUOUS_VERSION,
    CONV_VERSION,
    DRIVE_VERSION,
    FORMAT,
    FORMAT_VERSION,
    HISTORY_VERSION,
    INVALID_READING,
    NORMS_VERSION,
    TURNED_VERSION,
)
from jaxnav.robot.scan import scan_torso
from jaxnav.world import kinematics
from jaxnav.world.sensor import HISTORY_CHANGE_GAIN

NORM_EPSILON = 1e-6  # flax.linen.LayerNorm's default, as jaxnav.agent.networks.QNetwork uses it


def export_policy(
    run_dir: str | os.PathLike, strategy: str = "ebe", seed: int | None = None
) -> dict[str, np.ndarray]:
    """The arrays of a policy file for one trained (strategy, seed) of a run.

    ``seed`` defaults to the run's first seed. Raises PolicyError (one line) for a
    missing run directory, a run without params.npz, or an unknown strategy/seed.
    """
    run_dir = rundir.existing(run_dir, finished=True)
    cfg_path, params_path = run_dir / rundir.CONFIG, run_dir / rundir.PARAMS
    known = registry.names()
    if strategy.split(" ", 1)[0] not in known:
        raise PolicyError(f"unknown strategy '{strategy}' (choose from {', '.join(known)})")
    runs = rundir.runs_in(params_path)
    cfg = load_config(str(cfg_path))
    arms = dict(zip(cfg.arm_names(), cfg.arms()))
    if strategy in arms:  # a swept run's arm ("ebe ebe_temperature=0.1"): its own settings
        cfg = cfg.at(arms[strategy][1])
    seed = cfg.seed if seed is None else int(seed)
    if seed not in runs.get(strategy, []):
        have = "; ".join(f"{s} seeds {', '.join(map(str, v))}" for s, v in runs.items())
        raise PolicyError(
            f"{params_path} has no parameters for {strategy} seed {seed} (it has {have or 'none'})"
        )
    env, params = from_config(cfg, prepare=False)
    if env.waypoint:
        raise PolicyError(
            f"{run_dir}: a policy trained with env.waypoint cannot be exported yet "
            "(the robot side has no path to take the next waypoint from)"
        )
    if env.lidar_fov < 360.0 or env.robot != "burger":
        raise PolicyError(
            f"{run_dir}: a policy of the {env.robot} with a {env.lidar_fov:g}-degree LiDAR "
            "cannot be exported yet (the robot side reads the burger's 360-degree scan)"
        )
    if env.observe_moving:
        raise PolicyError(
            f"{run_dir}: a policy trained with env.observe_moving cannot be exported (it "
            "observes where the simulator's moving cylinders are: no robot sensor gives that)"
        )
    net = fold_dueling(rundir.load_params(params_path, strategy, seed).get("params", {}))
    outputs = 2 * env.action_size if env.continuous else len(np.asarray(params.omegas))
    torso = net.get("ScanTorso", {})
    convs = sorted(torso, key=lambda n: int(n.split("_")[1]))
    names = _dense_layers(net, _torso_width(env, torso, convs), outputs, params_path)
    norms = _norms(net, len(names) - 1, params_path)
    meta = _meta(cfg, env, params, strategy, seed, names, run_dir)
    if norms:  # PQN: read only by a reader that applies them
        meta.update(version=NORMS_VERSION, norms=norms, norm_epsilon=NORM_EPSILON)
    if env.normalised or params.speeds is not None or env.scan_beams:
        meta.update(version=DRIVE_VERSION, **_drive_meta(env, params))
    if env.continuous:  # a command per observation, which an older reader cannot run
        meta.update(version=CONTINUOUS_VERSION, **_continuous_meta(env))
    if env.scan_history:  # a longer observation, which an older reader cannot build
        meta.update(version=HISTORY_VERSION, scan_history=int(env.scan_history))
        if env.history_changes:
            meta.update(history_changes=True, history_change_gain=HISTORY_CHANGE_GAIN)
        if env.history_turned:  # the changes of turned scans, which version 5 cannot take
            meta.update(version=TURNED_VERSION, history_turned=True)
    if convs:  # the scan's convolutions first, which an older reader would skip
        layers = [f"ScanTorso/{n}" for n in convs]
        meta.update(
            version=CONV_VERSION,
            scan_conv={"layers": layers, "kernel": 5, "stride": 2, "layout": list(env.scan_layout)},
        )
    if not env.observe_command:  # zeros for the last command, which older readers feed
        meta.update(version=COMMAND_VERSION, observe_command=False)
    arrays: dict[str, np.ndarray] = {"meta": np.asarray(json.dumps(meta, indent=1))}
    for n in convs:
        arrays[f"ScanTorso/{n}/kernel"] = np.asarray(torso[n]["kernel"], np.float32)
        arrays[f"ScanTorso/{n}/bias"] = np.asarray(torso[n]["bias"], np.float32)
    for n in names:
        arrays[f"{n}/kernel"] = np.asarray(net[n]["kernel"], np.float32)
        arrays[f"{n}/bias"] = np.asarray(net[n]["bias"], np.float32)
    for n in norms:
        arrays[f"{n}/scale"] = np.asarray(net[n]["scale"], np.float32)
        arrays[f"{n}/bias"] = np.asarray(net[n]["bias"], np.float32)
    arrays["maze/walls"] = np.asarray(params.maze.walls(), np.float32)
    arrays["maze/obstacles"] = np.asarray(params.maze.obstacles(), np.float32)
    arrays["maze/start"] = np.asarray(params.maze.start, np.float32)
    return arrays


def default_strategy(run_dir: str | os.PathLike) -> str:
    """The arm ``export`` takes when none is named: EBE where the run trained it, else
    the run's first arm."""
    arms = load_config(str(Path(run_dir) / rundir.CONFIG)).arm_names()
    return "ebe" if "ebe" in arms else arms[0]


def best_seed(run_dir: str | os.PathLike, strategy: str) -> tuple[int, str]:
    """The seed of ``strategy`` with the best greedy success per goal attempt and a line
    saying by how much: from ``eval/results.csv`` (``jaxnav evaluate``; its success
    averaged over the test mazes), else from the last greedy evaluation while the run
    trained (``eval.csv``). PolicyError where the run has neither."""
    from jaxnav.report.navigation import seed_metrics
    from jaxnav.report.results import read_results

    run_dir = Path(run_dir)
    results = run_dir / "eval" / "results.csv"
    scores: dict[int, list[float]] = {}
    if results.is_file():
        where = f"{results} (greedy test, mean over its test mazes)"
        for (_, arm, seed), episodes in read_results(results.read_text()).items():
            if arm == strategy:
                scores.setdefault(seed, []).append(seed_metrics(episodes)["success"])
    elif (run_dir / rundir.EVAL).is_file():
        rows = [r for r in rundir.CsvLog(run_dir / rundir.EVAL, ()).read()]
        rows = [r for r in rows if r["strategy"] == strategy and r.get("success", "") != ""]
        last = max((int(r["env_step"]) for r in rows), default=None)
        where = f"{run_dir / rundir.EVAL} (the greedy evaluation at env step {last})"
        for r in rows:
            if int(r["env_step"]) == last:
                scores.setdefault(int(r["seed"]), []).append(float(r["success"]))
    else:
        raise PolicyError(
            f"{run_dir} has no greedy test to pick the best seed from: run "
            f"jaxnav evaluate {run_dir} first"
        )
    mean = {k: float(np.nanmean(v)) for k, v in scores.items() if np.isfinite(v).any()}
    if not mean:
        raise PolicyError(f"{where.split(' (')[0]} has no greedy success of {strategy}")
    ranked = sorted(mean, key=lambda k: (-mean[k], k))
    best = ranked[0]
    line = f"best seed of {strategy}: {best}, success {mean[best]:.3f} in {where}"
    if len(ranked) > 1:
        line += (
            f"; next seed {ranked[1]}: {mean[ranked[1]]:.3f}, median over "
            f"{len(ranked)} seeds {float(np.median(list(mean.values()))):.3f}"
        )
    return best, line


def fold_dueling(net: dict) -> dict:
    """A dueling network's parameters (``dqn.dueling``) as the plain network it equals:
    both streams are linear in the last hidden features, so Q = V + A - mean(A) is one
    linear layer, appended as the next ``Dense_<i>``. Other networks are unchanged."""
    if "value" not in net or "advantage" not in net:
        return net
    out = {k: v for k, v in net.items() if k not in ("value", "advantage")}
    v, a = net["value"], net["advantage"]
    ka, ba = np.asarray(a["kernel"], np.float64), np.asarray(a["bias"], np.float64)
    kernel = np.asarray(v["kernel"], np.float64) + ka - ka.mean(axis=1, keepdims=True)
    bias = np.asarray(v["bias"], np.float64) + ba - ba.mean()
    n = sum(1 for k in out if k.startswith("Dense_"))
    out[f"Dense_{n}"] = {"kernel": kernel.astype(np.float32), "bias": bias.astype(np.float32)}
    return out


def _dense_layers(net: dict, obs_size: int, num_actions: int, params_path: Path) -> list[str]:
    """The network's layer names in order, checked to map observations to action values."""
    names = sorted((n for n in net if n.startswith("Dense_")), key=lambda n: int(n.split("_")[1]))
    width = obs_size
    for n in names:
        k = np.asarray(net[n].get("kernel"))
        if k.ndim != 2 or k.shape[0] != width:
            raise PolicyError(f"{params_path}: layer {n} does not fit the run's observation layout")
        width = k.shape[1]
    if not names or width != num_actions:
        raise PolicyError(f"{params_path}: the network does not end in {num_actions} outputs")
    return names


def _torso_width(env, torso: dict, convs: list[str]) -> int:
    """The first dense layer's input width: the observation's, or what the robot's
    NumPy twin of the scan convolutions (:func:`jaxnav.robot.scan.scan_torso`) makes
    of one."""
    if not convs:
        return env.obs_size
    layers = [(np.asarray(torso[n]["kernel"]), np.asarray(torso[n]["bias"])) for n in convs]
    return scan_torso(np.zeros(env.obs_size), layers, env.scan_layout).shape[-1]


def _norms(net: dict, hidden: int, params_path: Path) -> list[str]:
    """The LayerNorm after each hidden layer (PQN's network), in order, or none."""
    names = sorted((n for n in net if n.startswith("LayerNorm_")), key=lambda n: int(n[10:]))
    if names and names != [f"LayerNorm_{i}" for i in range(hidden)]:
        raise PolicyError(f"{params_path}: the LayerNorms do not match the hidden layers")
    return names


def _meta(cfg, env, params, strategy: str, seed: int, names: list[str], run_dir: Path) -> dict:
    """The policy file's metadata: what a robot needs to build the observation and act."""
    fields = [f"range_{k}" for k in range(env.n_beams)] + ["heading", "distance"]
    if env.obstacle_obs:
        fields += ["min_range", "min_range_beam"]
    return {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "strategy": strategy,
        "seed": seed,
        "preset": cfg.preset,
        "maze": cfg.env.maze,
        "n_beams": env.n_beams,
        "obstacle_obs": bool(env.obstacle_obs),
        "min_range": float(params.min_range),
        "max_range": float(params.max_range),
        "beam_layout": env.beam_layout,
        "beam_angles": (
            "beam k at 2*pi*k/(n_beams - 1) rad (Gazebo's inclusive layout)"
            if env.beam_layout == "gazebo"
            else "beam k at 2*pi*k/n_beams rad"
        )
        + ", robot frame, counter-clockwise from ahead",
        "observation": fields,
        "omegas": [float(w) for w in np.asarray(params.omegas)],
        "linear_velocity": float(params.v),
        "dt": float(params.dt),
        "goal_radius": float(params.goal_radius),
        "robot_radius": float(params.robot_radius),
        "layers": names,
        "activation": "relu",
        "invalid_reading": INVALID_READING,
        "run_dir": str(run_dir.resolve()),
        "jaxnav_version": __version__,
        "config": dump_config(cfg),
    }


def _drive_meta(env, params) -> dict:
    """What a version-3 reader needs beyond version 2: the observation's kind and, per
    discrete action, its speed and the command the robot drives (the last-command
    part)."""
    import jax.numpy as jnp

    out = {
        "observation_kind": env.observation,
        "scan_beams": int(env.scan_beams),
        "command_scale": [BURGER_MAX_V, BURGER_MAX_OMEGA],
    }
    if not env.continuous:
        actions = jnp.arange(len(np.asarray(params.omegas)))
        v, omega = env.command(params, actions)
        v = np.broadcast_to(np.asarray(v, np.float64), np.asarray(omega).shape)
        speeds = np.broadcast_to(
            np.asarray(params.v if params.speeds is None else params.speeds, np.float64), v.shape
        )
        out["speeds"] = [float(x) for x in speeds]
        out["driven"] = [[float(a), float(b)] for a, b in zip(v, np.asarray(omega, np.float64))]
    if env.normalised:
        out["observation"] = [f"range_{k}/max_range" for k in range(env.n_beams)] + [
            "heading/pi",
            "min(distance, max_range)/max_range",
            "last_v/0.22",
            "last_omega/2.84",
        ]
    return out


def _continuous_meta(env) -> dict:
    """What a version-4 reader needs for continuous commands: the last layer's outputs
    (the mean, then the log standard deviation, of each of the action's 2 numbers; the
    command is tanh(mean)), the command's ranges and, where the run modelled it, the
    firmware's wheel limit with its constants (the driven command of the last-command
    part, :func:`jaxnav.world.kinematics.firmware_limit`)."""
    low, high = env.speed_range
    out = {
        "action_kind": "continuous",
        "outputs": "mean of (speed, yaw rate) in tanh space, then their log std",
        "speed_range": [float(low), float(high)],
        "max_yaw_rate": float(env.max_yaw_rate),
        "wheel_limit": None,
    }
    if env.wheel_limit:
        out["wheel_limit"] = {
            "max_linear": kinematics.MAX_LINEAR_VELOCITY,
            "max_angular": kinematics.MAX_ANGULAR_VELOCITY,
            "max_wheel": kinematics.MAX_WHEEL_SPEED,
            "wheel_separation": kinematics.WHEEL_SEPARATION,
        }
    return out


def save_policy(arrays: dict[str, np.ndarray], out: str | os.PathLike) -> None:
    """Write a policy file atomically (a reader sees the old file or the whole new one)."""
    out = Path(out)
    if not out.parent.is_dir():
        raise PolicyError(f"cannot write {out}: directory {out.parent} does not exist")
    try:
        rundir.atomic_write_npz(out, arrays)
    except OSError as e:
        raise PolicyError(f"cannot write {out} ({e.strerror or type(e).__name__})") from None
