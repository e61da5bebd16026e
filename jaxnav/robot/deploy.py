"""A trained policy on a real TurtleBot3: a policy file, read and run with NumPy alone.

``jaxnav export RUN_DIR [--strategy ebe] [--seed K] [--out policy.npz]``
writes one trained Q-network of a run to a portable ``.npz`` (plain arrays, no
pickle), together with everything needed to feed it:

    meta            JSON text: observation layout (n_beams, obstacle_obs, min_range,
                    max_range), preset, action angular velocities, linear velocity,
                    dt, goal radius, training maze, strategy, seed, the run's config
    Dense_<i>/kernel, Dense_<i>/bias   the network's layers (f32), in order
    LayerNorm_<i>/scale, LayerNorm_<i>/bias   PQN's LayerNorm after hidden layer i,
                    when meta lists them in "norms" (format version 2)
    ScanTorso/Conv_<i>/kernel, ScanTorso/Conv_<i>/bias   the circular convolutions over
                    the scan before the first layer, when meta lists them in "scan_conv"
                    (format version 7)
    maze/walls, maze/obstacles, maze/start   the training maze's geometry

``jaxnav export --info POLICY.npz`` prints the metadata.

On the robot, :class:`Policy` needs only NumPy: this module imports nothing else of
jaxnav but :mod:`jaxnav.robot.scan` (a contract in pyproject.toml checks that neither
imports JAX), so ``deploy.py`` and ``scan.py`` copied next to a ROS node run there::

    policy = Policy.load("policy.npz")
    linear, angular = policy.command(scan.ranges, scan.angle_min, scan.angle_increment,
                                     (x, y, yaw), (goal_x, goal_y))

How a raw LaserScan becomes the trained observation (:meth:`Policy.observe`):

* Beam reduction: trained beam k looks at 2 pi k / n_beams (robot frame, counter-
  clockwise from straight ahead), and the environment casts one exact ray there. The
  adapter does the same with the scan: it reads the single scan ray whose angle
  ``angle_min + i * angle_increment`` is nearest (circularly) to that direction;
  ties go to the lower ray index. Any start angle, any increment (negative for a
  clockwise scanner) works; with the LDS-01's 360 rays at 1 degree from 0 these are
  rays 0, 15, 30, ... exactly. Taking one ray, not a minimum over a sector, keeps
  the real input the same kind of reading the network was trained on. A scan that
  leaves a trained direction uncovered (no ray within one increment) is an error.
* Readings (REP 117 and the LDS-01 driver): ``+inf`` (no return) becomes max_range,
  as Gazebo's +inf became 3.5 in training; ``-inf`` (too close to measure) becomes
  min_range; invalid readings ``0``, ``nan`` and negative values become max_range
  too (:data:`INVALID_READING`), because the LDS-01 reports "no return" as 0 (spec:
  "inf or 0 for no return") and ROBOTIS' own collision test (``min_range > r > 0``)
  likewise ignores zero readings. Mapping them to min_range instead would put a
  phantom wall closer than the 0.13 m collision radius, a state the policy never
  saw (training episodes end there). Then everything is clipped to [min_range,
  max_range], as the environment does.
* Pooled scan (``scan_beams`` > 0, ``env.scan_beams``): the same nearest-ray reading
  at ``scan_beams`` evenly spread directions, cleaned, then the least of each trained
  beam's sector (:func:`pool_sectors`, as :func:`jaxnav.world.sensor.pooled_ranges`).
* Goal: heading = atan2(goal - position) - yaw wrapped to [-pi, pi), distance =
  |goal - position|, from the odometry pose (x, y, yaw) and the goal (x, y) in the
  same frame. With ``obstacle_obs`` the smallest range and its beam index follow.
* The normalised observation (``observation_kind: normalised``, the ``modern``
  preset): [ranges / max_range, heading / pi, min(distance, max_range) / max_range,
  the last command's (v, omega) / ``command_scale``]. The last command is what the
  robot drove for the policy's previous action (``driven``: per action, after the
  firmware's wheel limit where the run modelled it), and (0, 0) after a stop:
  :class:`Policy` keeps it (:meth:`Policy.command` sets it, :meth:`Policy.rest`
  clears it; :class:`Controller` clears it whenever it stops the robot).
  A policy trained without it (``observe_command`` false, ``env.observe_command``,
  format version 8) gets two zeros in its place.
* Scan history (``scan_history`` k > 0, ``env.scan_history``, format version 5): the
  normalised ranges of the k scans the policy acted on before this one follow the
  observation, newest first. :class:`Policy` keeps them: a scan joins when an action
  is taken on it (:meth:`Policy.take`), and after a stop (:meth:`Policy.rest`) the
  history starts again as copies of the next scan, as an episode's start does in the
  environment. With ``history_changes`` the observation holds each beam's change since
  each of those scans instead: (this scan - that scan) x ``history_change_gain``,
  clipped to [-1, 1] (:func:`jaxnav.world.sensor.history_changes`). With
  ``history_turned`` (format version 6) each earlier scan is first seen from the
  heading now, by the odometry's yaw turned since it (:func:`turned_changes`).

The network runs in float64 (exact ReLU MLP; dropout is off at inference; a PQN
network normalises each hidden layer before its ReLU, as flax's LayerNorm). A network
with scan convolutions (``dqn.scan_conv``, format version 7) first takes the scan and
each block of its history as channels, convolves them circularly over the beams (kernel
5, stride 2, ReLU; :func:`circular_conv`), flattens the result and puts the
observation's other values after it (:func:`scan_torso`).

A continuous policy (``action_kind: continuous``, format version 4, SAC's actor) ends
in 4 outputs, the mean and the log standard deviation of (speed, yaw rate) before the
tanh; the robot drives the mean command: a = tanh(mean), speed = low + (a_0 + 1) / 2
(high - low) over ``speed_range``, yaw rate = a_1 ``max_yaw_rate``. Its last command is
that command as the firmware drives it where the run modelled the wheel limit
(``wheel_limit``: the constants of :func:`jaxnav.world.kinematics.firmware_limit`).

:class:`jaxnav.robot.controller.Controller` is what a ROS node does with a policy (when
to drive, when to stop, when a goal is reached), shared by the ROS 1 and ROS 2 example
nodes and tested without ROS.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

try:  # inside the jaxnav package: its one error type
    from jaxnav.core.errors import PolicyError
except ImportError:  # deploy.py copied next to a robot's node, without jaxnav

    class PolicyError(ValueError):
        """A policy file, or a scan or pose it cannot use; one-line message."""


try:  # the scan's NumPy pieces: in the package, or scan.py beside this file
    from jaxnav.robot.scan import (
        _wrap,
        clean_ranges,
        goal_heading_distance,
        nearest_rays,
        pool_sectors,
        scan_torso,
        turned_changes,
    )
except ImportError:
    import importlib.util
    from pathlib import Path

    _spec = importlib.util.spec_from_file_location(
        "jaxnav_scan", Path(__file__).resolve().with_name("scan.py")
    )
    _scan = importlib.util.module_from_spec(_spec)
    _spec.loader.exec_module(_scan)
    _wrap, clean_ranges, goal_heading_distance = (
        _scan._wrap,
        _scan.clean_ranges,
        _scan.goal_heading_distance,
    )
    nearest_rays, pool_sectors = _scan.nearest_rays, _scan.pool_sectors
    scan_torso, turned_changes = _scan.scan_torso, _scan.turned_changes


FORMAT = "jaxnav-policy"
FORMAT_VERSION = 1
# A network with LayerNorm (PQN) is written as version 2, which a reader that does not
# know the norms refuses instead of running the network without them.
NORMS_VERSION = 2
# A policy with what version 2 cannot express (the normalised observation with the last
# command, (v, omega) actions, a pooled scan) is written as version 3.
DRIVE_VERSION = 3
# A continuous policy (SAC: the network gives a command, not action values) is version 4.
CONTINUOUS_VERSION = 4
# A policy that sees the scans before this one (env.scan_history) is version 5: an older
# reader would feed it a shorter observation.
HISTORY_VERSION = 5
# A policy whose history's changes are taken from the earlier scans turned to the
# heading now (env.history_turned) is version 6: a version-5 reader would take them
# unturned.
TURNED_VERSION = 6
# A network that starts with circular convolutions over the scan (dqn.scan_conv) is
# version 7: an older reader would feed its first dense layer the raw observation.
CONV_VERSION = 7
# A policy trained with two zeros where the normalised observation holds the last command
# (env.observe_command false; "observe_command": false) is version 8: an older reader
# would feed it the commands it never saw.
COMMAND_VERSION = 8
VERSIONS = (
    FORMAT_VERSION,
    NORMS_VERSION,
    DRIVE_VERSION,
    CONTINUOUS_VERSION,
    HISTORY_VERSION,
    TURNED_VERSION,
    CONV_VERSION,
    COMMAND_VERSION,
)
OBSERVATIONS = ("robotis", "normalised")
# The wheel limit's constants a continuous policy's metadata gives (its "wheel_limit").
WHEEL = ("max_linear", "max_angular", "max_wheel", "wheel_separation")
# Value given to invalid readings (0, nan, negative): the sensor's "no return".
INVALID_READING = "max_range"


# ----------------------------------------------------------------------------
# The policy
# ----------------------------------------------------------------------------


class Policy:
    """A trained Q-network plus its observation layout and action velocities.

    Attributes:
      meta: the exported metadata (dict).
      n_beams, obstacle_obs, min_range, max_range: observation layout.
      omegas: f64[A] angular velocity of each action (rad/s, + counter-clockwise).
      speeds: f64[A] forward speed of each action (m/s); ``linear_velocity`` for every
        action of the paper's set.
      linear_velocity: the paper's constant forward speed (m/s).
      observation: "robotis" or "normalised"; scan_beams: 0 or the pooled scan's size.
      scan_history: how many earlier scans the normalised observation holds (0: none);
      history_changes: whether it holds each beam's change since them instead;
      history_turned: whether each of those scans is seen from the heading now first.
      last_command: f64[2] (v, omega) the robot drove last (the normalised observation's).
      history: f32[scan_history, n_beams] the normalised scans acted on before, newest
        first, or None at an episode's start (the next scan's copies stand in);
        history_yaws: f64[scan_history] the odometry's yaw at each of them.
      dt: control period (s); goal_radius: the goal counts as reached within it (m).
    """

    def __init__(
        self,
        layers: Sequence[tuple[np.ndarray, np.ndarray]],
        meta: dict[str, Any],
        norms: Sequence[tuple[np.ndarray, np.ndarray]] = (),
        convs: Sequence[tuple[np.ndarray, np.ndarray]] = (),
    ):
        """``norms``: (scale, bias) of the LayerNorm after each hidden layer, or none;
        ``convs``: (kernel, bias) of each scan convolution before the first layer, or
        none."""
        try:
            self.n_beams = int(meta["n_beams"])
            self.obstacle_obs = bool(meta["obstacle_obs"])
            self.min_range = float(meta["min_range"])
            self.max_range = float(meta["max_range"])
            self.omegas = np.asarray(meta["omegas"], np.float64)
            self.linear_velocity = float(meta["linear_velocity"])
            self.dt = float(meta.get("dt", 0.2))
            self.goal_radius = float(meta.get("goal_radius", 0.2))
            self.beam_layout = str(meta.get("beam_layout", "even"))
            self.observation = str(meta.get("observation_kind", "robotis"))
            self.scan_beams = int(meta.get("scan_beams", 0))
            self.scan_history = int(meta.get("scan_history", 0))
            self.history_changes = bool(meta.get("history_changes", False))
            self.history_turned = bool(meta.get("history_turned", False))
            self.observe_command = bool(meta.get("observe_command", True))
            self.history_change_gain = np.float32(meta.get("history_change_gain", 0.0))
            speeds = meta.get("speeds", [self.linear_velocity] * len(self.omegas))
            self.speeds = np.asarray(speeds, np.float64)
            driven = meta.get("driven", np.stack([self.speeds, self.omegas], axis=-1))
            self.driven = np.asarray(driven, np.float64).reshape(len(self.omegas), 2)
            self.command_scale = np.asarray(meta.get("command_scale", (0.22, 2.84)), np.float64)
            self.continuous = meta.get("action_kind", "discrete") == "continuous"
            if self.continuous:
                low, high = (float(x) for x in meta["speed_range"])
                self.speed_range = (low, high)
                self.max_yaw_rate = float(meta["max_yaw_rate"])
                limit = meta.get("wheel_limit")
                self.wheel_limit = None if limit is None else {k: float(limit[k]) for k in WHEEL}
        except (KeyError, TypeError, ValueError) as e:
            raise PolicyError(f"policy metadata is incomplete or wrong ({e})") from None
        if self.beam_layout not in ("even", "gazebo"):
            raise PolicyError(f"policy metadata has an unknown beam_layout {self.beam_layout!r}")
        if self.observation not in OBSERVATIONS:
            raise PolicyError(f"policy metadata has an unknown observation {self.observation!r}")
        if self.speeds.shape != self.omegas.shape or self.command_scale.shape != (2,):
            raise PolicyError("policy metadata's speeds or command_scale do not fit its actions")
        if self.scan_beams and (self.scan_beams % self.n_beams or self.beam_layout != "even"):
            raise PolicyError(
                f"policy metadata's scan_beams {self.scan_beams} is not a multiple of its "
                f"{self.n_beams} evenly spread beams"
            )
        if self.scan_history < 0 or (self.scan_history and self.observation != "normalised"):
            raise PolicyError(
                f"policy metadata's scan_history {self.scan_history} needs a non-negative "
                "count and the normalised observation"
            )
        if self.history_changes and not (self.scan_history and self.history_change_gain > 0):
            raise PolicyError(
                "policy metadata's history_changes needs a scan_history and a positive "
                "history_change_gain"
            )
        if self.history_turned and not self.history_changes:
            raise PolicyError("policy metadata's history_turned needs history_changes")
        if not self.observe_command and self.observation != "normalised":
            raise PolicyError(
                "policy metadata's observe_command false needs the normalised observation"
            )
        self.last_command = np.zeros(2, np.float64)
        self.history: np.ndarray | None = None
        self.history_yaws: np.ndarray | None = None
        self._scan: np.ndarray | None = None  # the last observed scan, joins on take()
        self._yaw = 0.0  # and the yaw it was taken at
        self.meta = dict(meta)
        self.convs = [(np.asarray(k, np.float64), np.asarray(b, np.float64)) for k, b in convs]
        width = self._torso_width(meta)
        self.layers = [(np.asarray(k, np.float64), np.asarray(b, np.float64)) for k, b in layers]
        for i, (k, b) in enumerate(self.layers):
            if k.ndim != 2 or k.shape[0] != width or b.shape != (k.shape[1],):
                raise PolicyError(
                    f"policy layer {i} has shape {k.shape}/{b.shape}, expected ({width}, n)"
                )
            if not (np.isfinite(k).all() and np.isfinite(b).all()):
                raise PolicyError(f"policy layer {i} has non-finite weights")
            width = k.shape[1]
        outputs = 4 if self.continuous else len(self.omegas)
        if not self.layers or width != outputs:
            what = "a continuous command" if self.continuous else f"{len(self.omegas)} actions"
            raise PolicyError(f"policy network has {width} outputs for {what}")
        self.norms = [(np.asarray(g, np.float64), np.asarray(b, np.float64)) for g, b in norms]
        self.norm_epsilon = float(meta.get("norm_epsilon", 1e-6))
        if self.norms and len(self.norms) != len(self.layers) - 1:
            raise PolicyError(
                f"policy has {len(self.norms)} LayerNorms for {len(self.layers) - 1} hidden layers"
            )
        for i, ((g, b), (k, _)) in enumerate(zip(self.norms, self.layers)):
            if g.shape != (k.shape[1],) or b.shape != (k.shape[1],):
                raise PolicyError(f"policy LayerNorm {i} does not fit hidden layer {i}")
            if not (np.isfinite(g).all() and np.isfinite(b).all()):
                raise PolicyError(f"policy LayerNorm {i} has non-finite weights")

    def _torso_width(self, meta: dict[str, Any]) -> int:
        """The first layer's input width: the observation's, or what the scan
        convolutions make of it (their shapes checked against the layout)."""
        if not self.convs:
            return self.obs_size
        layout = list(self.conv_layout)
        conv = meta.get("scan_conv")
        given = conv.get("layout") if isinstance(conv, dict) else None
        if self.observation != "normalised" or given != layout:
            raise PolicyError(
                f"policy metadata's scan_conv layout {given} does not fit its normalised "
                f"observation {layout}"
            )
        width, channels = self.n_beams, 1 + self.scan_history
        for i, (k, b) in enumerate(self.convs):
            if k.ndim != 3 or k.shape[:2] != (5, channels) or b.shape != (k.shape[2],):
                raise PolicyError(
                    f"policy scan convolution {i} has shape {k.shape}/{b.shape}, expected "
                    f"(5, {channels}, n)/(n,)"
                )
            if not (np.isfinite(k).all() and np.isfinite(b).all()):
                raise PolicyError(f"policy scan convolution {i} has non-finite weights")
            width, channels = -(-width // 2), k.shape[2]
        return width * channels + 4

    @property
    def conv_layout(self) -> tuple[int, int, int]:
        """(beams, gap, history) of the normalised observation the scan convolutions
        read: an exported policy's gap is the 4 values of heading, distance and the
        last command."""
        return self.n_beams, 4, self.scan_history

    @property
    def obs_size(self) -> int:
        if self.observation == "normalised":
            return self.n_beams * (1 + self.scan_history) + 4
        return self.n_beams + 2 + (2 if self.obstacle_obs else 0)

    # -- files ---------------------------------------------------------------

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> Policy:
        """A policy from the arrays of an exported file (see :func:`export_policy`)."""
        if "meta" not in arrays:
            raise PolicyError("not a jaxnav policy (no 'meta' entry)")
        try:
            meta = json.loads(str(arrays["meta"]))
        except json.JSONDecodeError:
            raise PolicyError("policy metadata is not valid JSON") from None
        if meta.get("format") != FORMAT:
            raise PolicyError("not a jaxnav policy (wrong 'format' in its metadata)")
        if meta.get("version") not in VERSIONS:
            raise PolicyError(
                f"policy format version {meta.get('version')} is not one of "
                f"{', '.join(map(str, VERSIONS))}"
            )
        try:
            layers = [(arrays[f"{n}/kernel"], arrays[f"{n}/bias"]) for n in meta["layers"]]
            norms = [(arrays[f"{n}/scale"], arrays[f"{n}/bias"]) for n in meta.get("norms", [])]
            conv = meta.get("scan_conv") or {"layers": []}
            convs = [(arrays[f"{n}/kernel"], arrays[f"{n}/bias"]) for n in conv["layers"]]
        except KeyError as e:
            raise PolicyError(f"policy file lacks array {e}") from None
        except TypeError:
            raise PolicyError("policy metadata's scan_conv is not a mapping with layers") from None
        return cls(layers, meta, norms, convs)

    @classmethod
    def load(cls, path: str | os.PathLike) -> Policy:
        """Read a policy written by ``jaxnav export``."""
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
        except FileNotFoundError:
            raise PolicyError(f"no such policy file {path}") from None
        except Exception as e:  # not a zip, truncated, object arrays
            raise PolicyError(f"policy file {path} cannot be read ({type(e).__name__})") from None
        return cls.from_arrays(arrays)

    # -- inference -----------------------------------------------------------

    def q_values(self, obs: np.ndarray) -> np.ndarray:
        """f64[..., A] Q-values of observations f[..., obs_size] (the scan convolutions,
        if any, then the ReLU MLP, no dropout)."""
        x = np.asarray(obs, np.float64)
        if x.shape[-1:] != (self.obs_size,):
            raise ValueError(f"observation has shape {x.shape}, expected (..., {self.obs_size})")
        if self.convs:
            x = scan_torso(x, self.convs, self.conv_layout)
        for i, (k, b) in enumerate(self.layers):
            x = x @ k + b
            if i < len(self.layers) - 1:
                if self.norms:
                    scale, shift = self.norms[i]
                    mean = x.mean(axis=-1, keepdims=True)
                    var = x.var(axis=-1, keepdims=True)
                    x = (x - mean) / np.sqrt(var + self.norm_epsilon) * scale + shift
                x = np.maximum(x, 0.0)
        return x

    def act(self, obs: np.ndarray):
        """Greedy action(s): argmax of the Q-values (first of equal maxima); for a
        continuous policy its mean action f64[..., 2] in [-1, 1] (tanh of the mean)."""
        if self.continuous:  # the network's outputs: mean, then log std
            return np.tanh(self.q_values(obs)[..., :2])
        a = np.argmax(self.q_values(obs), axis=-1)
        return int(a) if a.ndim == 0 else a

    def scan_to_ranges(
        self,
        ranges: Sequence[float],
        angle_min: float,
        angle_increment: float,
        invalid: float | None = None,
    ) -> np.ndarray:
        """f32[n_beams]: a raw LaserScan reduced to the trained beams (module docstring)."""
        r = np.asarray(ranges, np.float64).reshape(-1)
        n = self.scan_beams or self.n_beams
        idx = nearest_rays(len(r), angle_min, angle_increment, n, self.beam_layout)
        beams = clean_ranges(r[idx], self.min_range, self.max_range, invalid)
        if self.scan_beams:
            beams = pool_sectors(beams, self.n_beams)
        return beams.astype(np.float32)

    def observe(
        self,
        ranges: Sequence[float],
        angle_min: float,
        angle_increment: float,
        pose: Sequence[float],
        goal: Sequence[float],
        invalid: float | None = None,
    ) -> np.ndarray:
        """f32[obs_size]: [ranges, heading, distance(, min range, its beam index)], or
        the normalised observation with the last command (module docstring)."""
        beams = self.scan_to_ranges(ranges, angle_min, angle_increment, invalid)
        heading, distance = goal_heading_distance(pose, goal)
        if self.observation == "normalised":
            scan = (beams / np.float32(self.max_range)).astype(np.float32)
            parts = [
                scan,
                [heading / math.pi, min(distance, self.max_range) / self.max_range],
                self.last_command / self.command_scale
                if self.observe_command
                else np.zeros(2),  # trained without it: its place held by zeros
            ]
            if self.scan_history:  # the scans acted on before (at a start: this one)
                self._scan, self._yaw = scan, float(pose[2])
                past = self._history_or(scan)
                if self.history_turned:  # each beam's change, the scans seen from here
                    yaws = self._yaws_or(self._yaw)
                    turned = _wrap(self._yaw - yaws)
                    past = turned_changes(scan, past, turned, self.history_change_gain)
                elif self.history_changes:  # or each beam's change since each of them
                    past = np.clip((scan[None] - past) * self.history_change_gain, -1, 1)
                parts.append(past.reshape(-1))
            return np.concatenate(parts).astype(np.float32)
        parts = [beams, np.asarray([heading, distance], np.float32)]
        if self.obstacle_obs:
            parts.append(np.asarray([beams.min(), np.argmin(beams)], np.float32))
        return np.concatenate(parts).astype(np.float32)

    def command(
        self,
        ranges: Sequence[float],
        angle_min: float,
        angle_increment: float,
        pose: Sequence[float],
        goal: Sequence[float],
        invalid: float | None = None,
    ) -> tuple[float, float]:
        """(linear m/s, angular rad/s) of the greedy action for a raw scan and a pose.

        Args:
          ranges: the LaserScan's ranges in metres (inf: no return; 0/nan: invalid).
          angle_min, angle_increment: the LaserScan's angles (rad, robot frame, CCW).
          pose: odometry (x, y, yaw); goal: (x, y) in the same frame.
          invalid: value for invalid readings (default max_range).
        """
        return self.drive(self.observe(ranges, angle_min, angle_increment, pose, goal, invalid))

    def drive(self, obs: np.ndarray) -> tuple[float, float]:
        """(linear m/s, angular rad/s) of the greedy action for one observation; the
        action's driven command becomes the next observation's last command."""
        return self.take(self.act(obs))

    def take(self, action) -> tuple[float, float]:
        """(linear m/s, angular rad/s) of one action (a continuous policy's: f[2] in
        [-1, 1], clipped there); its driven command becomes the next observation's last
        command."""
        if self.scan_history and self._scan is not None:  # the scan acted on joins
            older = self._history_or(self._scan)
            self.history = np.concatenate([self._scan[None], older[:-1]])
            if self.history_turned:  # and the yaw it was taken at
                yaws = self._yaws_or(self._yaw)
                self.history_yaws = np.concatenate([[self._yaw], yaws[:-1]])
            self._scan = None
        if self.continuous:
            a = np.clip(np.asarray(action, np.float64).reshape(2), -1.0, 1.0)
            low, high = self.speed_range
            v, omega = low + (a[0] + 1.0) * 0.5 * (high - low), a[1] * self.max_yaw_rate
            self.last_command = np.asarray(self.driven_command(v, omega), np.float64)
            return float(v), float(omega)
        self.last_command = self.driven[action].copy()
        return float(self.speeds[action]), float(self.omegas[action])

    def _history_or(self, scan: np.ndarray) -> np.ndarray:
        """The scan history, or at an episode's start ``scan``'s copies."""
        if self.history is None:
            return np.tile(scan, (self.scan_history, 1))
        return self.history

    def _yaws_or(self, yaw: float) -> np.ndarray:
        """The history's yaws, or at an episode's start ``yaw`` for each."""
        if self.history_yaws is None:
            return np.full(self.scan_history, yaw, np.float64)
        return self.history_yaws

    def driven_command(self, v: float, omega: float) -> tuple[float, float]:
        """(v, omega) the robot drives for a command: the firmware's clip of the command
        and of each wheel where the policy's run modelled it (the arithmetic of
        :func:`jaxnav.world.kinematics.firmware_limit`, with its constants from the
        metadata), else the command itself."""
        w = getattr(self, "wheel_limit", None)
        if w is None:
            return v, omega
        v = min(max(v, -w["max_linear"]), w["max_linear"])
        omega = min(max(omega, -w["max_angular"]), w["max_angular"])
        half = omega * w["wheel_separation"] / 2
        left = min(max(v - half, -w["max_wheel"]), w["max_wheel"])
        right = min(max(v + half, -w["max_wheel"]), w["max_wheel"])
        return (left + right) / 2, (right - left) / w["wheel_separation"]

    def rest(self) -> None:
        """The robot stopped: the next observation's last command is (0, 0) and its scan
        history starts again, as at an episode's start."""
        self.last_command = np.zeros(2, np.float64)
        self.history = None
        self.history_yaws = None
        self._scan = None
