"""A Gymnasium ``Env`` around the JAX environment, for libraries that expect one.

NumPy in and out, one robot, no auto-reset inside ``step`` (Gymnasium's contract:
call ``reset`` after ``terminated`` or ``truncated``). Stable-Baselines3, RLlib's
single-agent path and Gymnasium's own wrappers take it as is::

    import gymnasium as gym
    import jaxnav.interop.gym  # registers jaxnav/Square4-v0, jaxnav/Square4Obstacles-v0, ...

    env = gym.make("jaxnav/Square4-v0")                    # paper preset, 24 beams
    env = gym.make("jaxnav/Square4-v0", n_beams=360, lidar_noise_std=0.01)
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(2)

``gym.make("jaxnav.interop.gym:jaxnav/Square4-v0")`` imports this module by itself. Extra
keyword arguments go to :func:`jaxnav.make` (``preset``, any ``EnvParams`` or
``NavEnv`` field). Only this module imports ``gymnasium``.

Episodes follow TurtleBot3, as the JAX ``step`` does: the first ``reset`` draws a
goal; a later ``reset()`` (after a collision or the step limit) puts the robot back
at the maze's start pose and keeps its goal. ``reset(seed=...)`` or
``reset(options={"new_goal": True})`` starts afresh with a new goal. The step limit
(``max_steps``, 500) is the environment's own ``truncated``; no ``TimeLimit``
wrapper is added.

Seeding, exactly (so a trajectory can be replayed with the JAX functions):

* ``reset(seed=s)`` sets the wrapper's key to ``jax.random.PRNGKey(s % 2**32)``
  (JAX seeds are 32-bit); the first ``reset()`` without a seed takes ``s`` from
  ``self.np_random`` (random entropy unless Gymnasium seeded it).
* Every ``reset`` and ``step`` then does ``key, sub = jax.random.split(key)`` and
  calls, with ``sub``: ``NavEnv.reset`` (fresh start), ``NavEnv.step_env`` (step),
  or, for the restart, the restart branch of ``NavEnv.step``'s auto-reset (start
  pose, kept goal; its pose draw, if ``random_start``, and its observation both use
  ``sub``).

The reset and step functions are compiled once per instance, with the maze and
parameters baked in as constants: one dispatch per call.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
from gymnasium import spaces

from jaxnav.env import EnvParams, EnvState, NavEnv, make
from jaxnav.world.maps import BUILTIN_MAZES, Maze

NAMESPACE = "jaxnav"
VERSION = 0


def env_id(maze: str) -> str:
    """Gymnasium id of a built-in maze: ``square4_obstacles`` -> ``jaxnav/Square4Obstacles-v0``."""
    return f"{NAMESPACE}/{''.join(p.capitalize() for p in maze.split('_'))}-v{VERSION}"


ENV_IDS: dict[str, str] = {m: env_id(m) for m in BUILTIN_MAZES}


def _restart(env: NavEnv, key, state: EnvState, params: EnvParams):
    """TurtleBot3 restart after a collision or the step limit (``NavEnv.restart``)."""
    return env.restart(key, state, params)


class NavGymEnv(gymnasium.Env):
    """One jaxnav robot as a ``gymnasium.Env`` (observations f32[obs_size], 5 actions).

    Args:
      maze: a built-in maze name, a maze YAML file, or a ``Maze``.
      preset: ``"paper"`` (default) or ``"robotis"``.
      render_mode: ``None`` or ``"rgb_array"`` (a matplotlib picture of the maze,
        robot, goal and beams; slow, for looking, not for training).
      **overrides: passed to :func:`jaxnav.make` (``n_beams=360``, ``max_steps=200``,
        ``lidar_noise_std=0.01``, ...).

    Attributes:
      jax_env, jax_params: the underlying ``NavEnv`` and ``EnvParams``.
      state: the current ``EnvState`` (JAX arrays), None before the first reset.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 5}  # dt = 0.2 s

    def __init__(
        self,
        maze: str | Maze = "square4",
        preset: str = "paper",
        render_mode: str | None = None,
        **overrides: Any,
    ):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        self.render_mode = render_mode
        env, params = make(maze, preset, **overrides)
        self.jax_env, self.jax_params = env, params
        box = env.observation_space(params)
        self.observation_space = spaces.Box(
            low=np.asarray(box.low, np.float32),
            high=np.asarray(box.high, np.float32),
            shape=box.shape,
            dtype=np.float32,
        )
        if env.continuous:  # (speed, yaw rate) in [-1, 1] each (env.actions continuous)
            self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        else:
            self.action_space = spaces.Discrete(env.num_actions)
        self.state: EnvState | None = None
        self._key = None

        def fresh(key):
            key, sub = jax.random.split(key)
            obs, state = env.reset(sub, params)
            return key, obs, state

        def restart(key, state):
            key, sub = jax.random.split(key)
            obs, state = _restart(env, sub, state, params)
            return key, obs, state

        def step(key, state, action):
            key, sub = jax.random.split(key)
            obs, state, reward, terminated, truncated, info = env.step_env(
                sub, state, action, params
            )
            # One f32 array back to the host instead of six small ones (fewer copies).
            flags = jnp.stack([terminated, truncated, info["goal_reached"], info["collision"]])
            return key, state, jnp.concatenate([obs, reward[None], flags.astype(jnp.float32)])

        self._fresh = jax.jit(fresh)
        self._restart = jax.jit(restart)
        self._step = jax.jit(step)

    # -- Gymnasium API -----------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        options = options or {}
        unknown = set(options) - {"new_goal"}
        if unknown:
            raise ValueError(f"unknown reset option '{sorted(unknown)[0]}' (known: new_goal)")
        if seed is not None or self._key is None:
            s = seed if seed is not None else int(self.np_random.integers(2**32))
            self._key = jax.random.PRNGKey(s % 2**32)
            self._key, obs, self.state = self._fresh(self._key)
        elif options.get("new_goal", False):
            self._key, obs, self.state = self._fresh(self._key)
        else:
            self._key, obs, self.state = self._restart(self._key, self.state)
        return np.array(obs), {}

    def step(self, action) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self.state is None:
            raise RuntimeError("call reset() before step()")
        a = np.asarray(action)
        if self.jax_env.continuous:
            if a.shape != (2,) or not np.all(np.isfinite(a)) or np.any(np.abs(a) > 1.0):
                raise ValueError(f"action must be 2 finite numbers in [-1, 1], got {action!r}")
            self._key, self.state, out = self._step(self._key, self.state, a.astype(np.float32))
            return self._split(out)
        if (
            a.size != 1
            or not np.issubdtype(a.dtype, np.integer)
            or not 0 <= int(a) < self.action_space.n
        ):
            raise ValueError(
                f"action must be an integer in [0, {self.action_space.n}), got {action!r}"
            )
        self._key, self.state, out = self._step(self._key, self.state, np.int32(a.item()))
        return self._split(out)

    def _split(self, out) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """A step's packed output as Gymnasium's (obs, reward, terminated, truncated, info)."""
        out = np.asarray(out)
        d = self.observation_space.shape[0]
        terminated, truncated, reached, collided = (bool(f) for f in out[d + 1 :])
        info = {"goal_reached": reached, "collision": collided}
        return out[:d].copy(), float(out[d]), terminated, truncated, info

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gymnasium.logger.warn("render() called without a render_mode; returning None")
            return None
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        from jaxnav.experiments.scene import draw_maze

        p, s = self.jax_params, self.state
        fig = Figure(figsize=(4, 4), dpi=80)
        canvas = FigureCanvasAgg(fig)
        ax = fig.add_subplot()
        if s is None:
            draw_maze(ax, p.maze)
        else:
            x, y = np.asarray(s.pos, np.float64)
            draw_maze(
                ax,
                p.maze,
                pose=(x, y, float(s.yaw)),
                goal=np.asarray(s.goal),
                n_beams=self.jax_env.n_beams,
                robot_radius=float(p.robot_radius),
                goal_radius=float(p.goal_radius),
                min_range=float(p.min_range),
                max_range=float(p.max_range),
            )
        fig.tight_layout()
        canvas.draw()
        return np.array(canvas.buffer_rgba())[..., :3]


def register_envs() -> None:
    """Register ``jaxnav/<Maze>-v0`` for every built-in maze (done on import)."""
    for maze, id_ in ENV_IDS.items():
        if id_ not in gymnasium.registry:
            gymnasium.register(
                id=id_,
                entry_point="jaxnav.interop.gym:NavGymEnv",
                kwargs={"maze": maze},
                max_episode_steps=None,  # the env truncates itself at max_steps
                nondeterministic=False,
            )


register_envs()

__all__ = ["NavGymEnv", "ENV_IDS", "env_id", "register_envs"]
