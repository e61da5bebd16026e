"""The test rollout: a trained policy played in the environment, a pure function to
jit and vmap over runs.

The paper's test protocol (Sec. 6): every policy plays N consecutive test episodes
in one environment; after a collision or truncation the robot restarts at the
start pose and keeps its goal (the env's auto-reset), as in the paper's Gazebo
runs. Greedy: dropout off, no exploration, action = argmax Q. Both strategies of a
seed use the same test key (:func:`eval_keys`). The tests of finished runs
(:mod:`jaxnav.experiments.rollout`) and the greedy evaluation while a run trains
(:mod:`jaxnav.run.greedy`) both play it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

import chex
import jax
import jax.numpy as jnp

from jaxnav.agent.episodes import Episodes
from jaxnav.agent.exploration import explore_action
from jaxnav.agent.hyper import Hyper
from jaxnav.env import EnvParams, EnvState, NavEnv

if TYPE_CHECKING:  # only the network's apply is called here
    from jaxnav.agent.networks import QNetwork

EVAL_SALT = 0x7E57  # folded into a seed's key: test goals differ from training's
# folded into a seed's key: the held-out episodes that choose a run's best policy
# (run.keep_best) differ from the test's and from training's
VALID_SALT = 0xBE57


class Planner(Protocol):
    """A driver that is not a Q-network (the reference drivers of
    :mod:`jaxnav.planners`): it may read the environment's state and keeps a memory
    between steps. The rollout plays it exactly as it plays a learned policy."""

    def start(self, params: EnvParams, state: EnvState) -> Any:
        """Its memory at the test's first step."""

    def plan(self, memory: Any, obs: chex.Array, state: EnvState, params: EnvParams):
        """(action i32[], memory) for the step from ``state``."""


class Trajectory(NamedTuple):
    """Per-step record of a rollout; the pose is the one *before* the step.

    Leading axes [..., T] (T = n_episodes * max_steps); steps after the last test
    episode have ``episode == n_episodes`` and are not part of the test.
    """

    pos: chex.Array  # f32[..., T, 2]
    yaw: chex.Array  # f32[..., T]
    goal: chex.Array  # f32[..., T, 2]
    ranges: chex.Array  # f32[..., T, n_beams] the scan the policy saw
    action: chex.Array  # i32[..., T]; f32[..., T, 2] for continuous actions
    reward: chex.Array  # f32[..., T]
    reached: chex.Array  # bool[..., T] the goal was reached in this step
    collided: chex.Array  # bool[..., T] the robot collided in this step
    episode: chex.Array  # i32[..., T] test episode of this step
    # f32[..., T, k, 3] every cylinder where it was at the step's start, for mazes whose
    # cylinders move; None otherwise.
    circles: chex.Array | None = None


class Steps(NamedTuple):
    """What the navigation metrics need of every step (jaxnav.report.navigation):
    the pose's position and the goal before the step, what the step did, its test
    episode. Leading axes [..., T], as :class:`Trajectory`."""

    pos: chex.Array  # f32[..., T, 2]
    goal: chex.Array  # f32[..., T, 2]
    reached: chex.Array  # bool[..., T]
    collided: chex.Array  # bool[..., T]
    episode: chex.Array  # i32[..., T]
    travel: chex.Array  # f32[..., T] the path the step drove, m (|v| dt along its arc)
    command: chex.Array | None = None  # f32[..., T, 2] the (v, omega) the step drove


class EpisodeMazes(NamedTuple):
    """The maze each test episode was played in, [..., E] (the state's maze at the
    episode's first step, scaled as the episode scaled it): recorded where it can
    differ from the test maze, with drawn mazes or ``maze_scale``."""

    segments: chex.Array  # f32[..., E, S, 4]
    segment_mask: chex.Array  # bool[..., E, S]
    circles: chex.Array  # f32[..., E, C, 3]
    circle_mask: chex.Array  # bool[..., E, C]


class Rollout(NamedTuple):
    """Per-episode test results [..., n_episodes] and, optionally, the trajectory,
    the steps the navigation metrics need and each episode's maze."""

    ret: chex.Array  # f32[..., E]
    goals: chex.Array  # i32[..., E]
    collided: chex.Array  # bool[..., E]
    length: chex.Array  # i32[..., E]
    trajectory: Trajectory | None
    steps: Steps | None = None
    mazes: EpisodeMazes | None = None


def make_rollout(
    env: NavEnv,
    network: QNetwork | Planner,
    n_episodes: int,
    max_steps: int,
    record: bool = False,
    exploring: int | None = None,
    navigation: bool = False,
):
    """A pure ``rollout(params, key, strategy, hyper, env_params) -> Rollout`` of one
    policy; ``hyper`` is its settings in training (its swept environment settings
    apply to the test too). ``network`` is the policy's Q-network, or a
    :class:`Planner` (then ``params`` and ``strategy`` are not read and the test is
    greedy: the planner's own choice).

    ``record`` keeps the whole :class:`Trajectory`; ``navigation`` the light
    :class:`Steps` and, where an episode's maze can differ from ``env_params``'s
    (drawn mazes, ``maze_scale``), each episode's maze (:class:`EpisodeMazes`).

    Plays ``n_episodes`` consecutive episodes in one environment with auto-reset.
    Each episode lasts at most ``max_steps`` steps, so a scan of
    ``n_episodes * max_steps`` steps always completes them; later steps are ignored.

    Greedy (``exploring`` None): dropout off, action = argmax Q (a continuous agent:
    its mean command; exploring, its sampled one). Exploring
    (``exploring`` = the episodes trained): each strategy explores
    as at the end of its training, through the trainer's own
    :func:`jaxnav.agent.exploration.explore_action` (EBE with probability H(s), epsilon-greedy with
    the schedule's last epsilon, Boltzmann sampling softmax(Q / T)); the environment's
    keys are the greedy test's, so both modes start from the same goals.
    """
    n_steps = n_episodes * max_steps
    E = n_episodes
    own_mazes = navigation and (env.generates or env.scales_maze)
    planner = network if hasattr(network, "plan") else None

    # One scan body over one explicit carry, read top to bottom: ACT, STEP ENV, RECORD.

    def act(params, obs, key, strategy, hyper):
        if env.continuous:  # the actor's mean command, or its sample when exploring
            if exploring is None:
                return network.apply(params, obs)
            return network.apply(params, obs, jax.random.fold_in(key, 1))[0]
        q = network.apply(params, obs)  # dropout off (Keras predict)
        if exploring is None:
            return jnp.argmax(q, axis=-1).astype(jnp.int32)
        k_act, episodes = jax.random.fold_in(key, 1), jnp.int32(exploring)
        action, _ = explore_action(strategy, k_act, q, episodes, hyper)
        return action.astype(jnp.int32)

    def rollout(params, key: chex.PRNGKey, strategy, hyper: Hyper, env_params: EnvParams):
        env_params = hyper.env_params(env_params)
        moves = env_params.maze.motion is not None  # record where the cylinders were
        k_reset, key = jax.random.split(key)
        obs, state = env.reset(k_reset, env_params)
        # the episode being played, and the test's episodes (jaxnav.agent.episodes)
        mazes0 = _episode_mazes(env, env_params, state, E) if own_mazes else None
        memory = None if planner is None else planner.start(env_params, state)
        ep0 = jnp.zeros((), jnp.int32)
        carry0 = (obs, state, key, ep0, Episodes.zeros(E), mazes0, memory)

        def body(carry, _):
            obs, state, key, ep, episodes, mazes, memory = carry
            if own_mazes:  # the maze of an episode, at its first step (slot E: dropped)
                first = jnp.where((state.t == 0) & (ep < E), ep, E)
                mazes = _record_maze(mazes, first, _geometry(env, env_params, state))
            key, k_step = jax.random.split(key)
            # ACT: greedy, or the strategy's own exploration; or the planner's choice.
            with jax.named_scope("act"):
                if planner is None:
                    action = act(params, obs, k_step, strategy, hyper)
                else:
                    action, memory = planner.plan(memory, obs, state, env_params)
            # STEP ENV (auto-reset keeps the goal, restarts at the start pose).
            with jax.named_scope("env_step"):
                obs2, state2, reward, terminated, truncated, info = env.step(
                    k_step, state, action, env_params
                )
            done = terminated | truncated
            # RECORD the step and the finished episode (slot E: dropped, the test is over).
            slot = jnp.where(done & (ep < E), ep, E)
            episodes = episodes.record(slot, reward, info["goal_reached"], terminated, done)
            steps = traj = None
            if navigation:
                moved = env.travel(env_params, state, action)
                v, omega = env.driven(env_params, state, action)
                command = jnp.stack([v, omega]).astype(jnp.float32)
                steps = Steps(
                    state.pos, state.goal, info["goal_reached"], terminated, ep, moved, command
                )
            if record:
                traj = Trajectory(
                    pos=state.pos,
                    yaw=state.yaw,
                    goal=state.goal,
                    ranges=obs[: env.n_beams],
                    action=action,
                    reward=reward,
                    reached=info["goal_reached"],
                    collided=terminated,
                    episode=ep,
                    circles=state.circles if moves else None,
                )
            carry = (obs2, state2, key, ep + done.astype(jnp.int32), episodes, mazes, memory)
            return carry, (steps, traj)

        carry, (steps, traj) = jax.lax.scan(body, carry0, None, length=n_steps)
        e, mazes = carry[4], carry[5]
        return Rollout(e.ep_return, e.ep_goals, e.ep_collided, e.ep_length, traj, steps, mazes)

    return rollout


def _geometry(env: NavEnv, env_params: EnvParams, state) -> EpisodeMazes:
    """The walls and circles of the state's episode (its maze, scaled as it is)."""
    maze = env.episode_maze(env_params, state)
    return EpisodeMazes(maze.segments, maze.segment_mask, maze.circles, maze.circle_mask)


def _episode_mazes(env: NavEnv, env_params: EnvParams, state, n: int) -> EpisodeMazes:
    """Room for ``n`` episodes' mazes, shaped as the state's."""
    one = _geometry(env, env_params, state)
    return EpisodeMazes(*(jnp.zeros((n,) + a.shape, a.dtype) for a in one))


def _record_maze(mazes: EpisodeMazes, slot: chex.Array, one: EpisodeMazes) -> EpisodeMazes:
    return EpisodeMazes(*(a.at[slot].set(b, mode="drop") for a, b in zip(mazes, one)))


def eval_keys(labels: Sequence[tuple[str, int]], salt: int = EVAL_SALT) -> chex.Array:
    """Test key per run: a seed's key with ``salt`` folded in (shared by strategies);
    VALID_SALT gives the held-out episodes of run.keep_best."""
    return jnp.stack([jax.random.fold_in(jax.random.PRNGKey(seed), salt) for _, seed in labels])
