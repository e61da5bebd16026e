"""The built-in agents' own settings checks and memory estimates (registered with them
in :mod:`jaxnav.core.agents`): what DQN and PQN need of a config beyond each setting's
own rule, and the bytes their runs' largest arrays take. No JAX."""

from __future__ import annotations

from jaxnav.core.agent_sections import PRIORITISED_ONLY, REPLAY_ONLY
from jaxnav.core.config import SETTINGS, Config
from jaxnav.core.settings import PRESETS


def network_problem(cfg: Config) -> str | None:
    """The Q-network's settings together: its scan convolutions read the normalised
    observation's layout."""
    if cfg.dqn.scan_conv and cfg.env.observation != "normalised":
        return (
            "dqn.scan_conv convolves the normalised observation's scan: it needs "
            "env.observation normalised"
        )
    return None


def dqn_problem(cfg: Config) -> str | None:
    """DQN's settings together: the network's (:func:`network_problem`), prioritised
    replay's settings need it on, and a batch fits the replay memory."""
    if problem := network_problem(cfg):
        return problem
    for name in PRIORITISED_ONLY if not cfg.dqn.prioritised else ():
        if getattr(cfg.dqn, name) != SETTINGS[f"dqn.{name}"].default:
            return f"dqn.{name} is a prioritised replay setting: it needs dqn.prioritised true"
    capacity = cfg.buffer_capacity
    if cfg.dqn.batch_size > capacity:
        return (
            f"dqn.batch_size ({cfg.dqn.batch_size}) is larger than the replay memory, "
            f"{capacity} transitions (the smaller of dqn.buffer_size and the most steps a "
            "run takes)"
        )
    return None


def pqn_problem(cfg: Config) -> str | None:
    """PQN has no replay memory and no target network, so their settings keep their
    defaults (the preset's); its minibatches split its rollout evenly."""
    defaults = PRESETS[cfg.preset].training()
    for name in REPLAY_ONLY:
        key = f"dqn.{name}"
        if getattr(cfg.dqn, name) != defaults.get(key, SETTINGS[key].default):
            return (
                f"{key} is a replay or target-network setting, and PQN (agent pqn) has "
                "neither: leave it at its default"
            )
    if problem := network_problem(cfg):
        return problem
    p = cfg.pqn
    if (p.num_envs * p.rollout) % p.minibatches:
        return (
            f"pqn.minibatches ({p.minibatches}) must divide pqn.num_envs x pqn.rollout "
            f"({p.num_envs * p.rollout} transitions per update)"
        )
    return level_replay_problem(cfg)


def level_replay_problem(cfg: Config) -> str | None:
    """Level replay picks from a bank that stays the run's own: it needs drawn mazes
    with env.maze_bank and no env.maze_bank_refresh; its other settings need it on."""
    p, e = cfg.pqn, cfg.env
    if not p.level_replay:
        for name in ("level_top", "level_halflife"):
            if getattr(p, name) != SETTINGS[f"pqn.{name}"].default:
                return f"pqn.{name} is a level replay setting: it needs pqn.level_replay above 0"
        return None
    if not (e.generator and e.maze_bank):
        return (
            "pqn.level_replay picks layouts from a bank: it needs drawn mazes "
            "(env.generator) with env.maze_bank"
        )
    if e.maze_bank_refresh:
        return "pqn.level_replay scores the layouts of one bank: it needs env.maze_bank_refresh 0"
    if round(p.level_top * e.maze_bank) < 1:
        return (
            f"pqn.level_top ({p.level_top}) of env.maze_bank ({e.maze_bank}) is no layout: raise it"
        )
    return None


def dqn_memory(cfg: Config) -> int:
    """Bytes DQN's replay memories take, an upper bound within 10% (for 24 beams):
    jaxnav.agent.replay keeps per slot a record of an f32 observation of at most
    n_beams + 4 values and 12 bytes of reward, action and flags, and ring index, a ring
    of capacity // max_steps + 2 final observations and, with prioritised replay, a sum
    tree; the networks and the environment are small beside it."""
    obs = 4 * (cfg.env.n_beams + 4)
    capacity = cfg.buffer_capacity
    ring = capacity // cfg.env.max_steps + 3  # the final-observation ring and tail
    # prioritised replay's sum tree: f32[2P], P the power of two at or above capacity
    tree = 8 << max(0, (capacity - 1).bit_length()) if cfg.dqn.prioritised else 0
    return cfg.n_runs * (capacity * (obs + 12) + ring * obs + 12 + tree)  # + 3 counters


def pqn_memory(cfg: Config) -> int:
    """Bytes of PQN's rollouts: num_envs x rollout transitions (observation, next
    observation, Q-values, a dozen scalars) per run, the largest array it holds."""
    obs = 4 * (cfg.env.n_beams + 4)
    return cfg.n_runs * cfg.pqn.num_envs * cfg.pqn.rollout * (2 * obs + 64)


def sac_problem(cfg: Config) -> str | None:
    """SAC's settings together: the scan convolutions read the normalised
    observation's layout, a shared torso needs them, the actor's period divides the
    gradient steps, and a batch fits the replay memory."""
    s = cfg.sac
    if s.scan_conv and cfg.env.observation != "normalised":
        return (
            "sac.scan_conv convolves the normalised observation's scan: it needs "
            "env.observation normalised"
        )
    if s.shared_torso and not s.scan_conv:
        return "sac.shared_torso shares the scan convolutions: it needs sac.scan_conv"
    if s.lr_decay and cfg.total_steps is None:
        return "sac.lr_decay needs total_steps: the decay spans the run's budget of env steps"
    if s.updates % s.actor_every:
        return (
            f"sac.actor_every ({s.actor_every}) must divide sac.updates ({s.updates}): the "
            "actor steps after every actor_every-th of each env step's critic steps"
        )
    capacity = sac_capacity(cfg)
    if s.batch_size > capacity:
        return (
            f"sac.batch_size ({s.batch_size}) is larger than the replay memory, {capacity} "
            "transitions (the smaller of sac.buffer_size and the most steps a run takes)"
        )
    return None


def sac_capacity(cfg: Config) -> int:
    """SAC's replay capacity per run: sac.buffer_size, at most the run's env steps (a
    whole step of every environment more)."""
    s = cfg.sac
    most = cfg.max_total_steps + s.num_envs if cfg.total_steps is not None else s.buffer_size
    return max(s.num_envs, min(s.buffer_size, most))


def sac_memory(cfg: Config) -> int:
    """Bytes of SAC's replay memories: per transition an observation and the next one
    (f32, n_beams + 4 values, more with a scan history or a waypoint), a 2-number
    action and three scalars."""
    obs = 4 * (cfg.env.n_beams * (1 + cfg.env.scan_history) + 6)
    return cfg.n_runs * sac_capacity(cfg) * (2 * obs + 20)


__all__ = ["dqn_memory", "dqn_problem", "pqn_memory", "pqn_problem", "sac_memory", "sac_problem"]
