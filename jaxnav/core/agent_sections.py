"""The agents' sections of the config: DQN's (the paper's agent, and the optimiser,
network and replay settings PQN shares), PQN's and SAC's, each setting declared once with
:func:`jaxnav.core.settings.setting`, as :mod:`jaxnav.core.sections` declares the rest."""

from __future__ import annotations

from dataclasses import dataclass

from jaxnav.core.settings import (
    AT_LEAST_1,
    CHANNELS,
    POSITIVE,
    PRESETS,
    UNIT,
    UNIT_OPEN,
    WIDTHS,
    one_of,
    setting,
)


@dataclass(frozen=True)
class DQNConfig:
    gamma: float = setting(PRESETS["paper"].gamma, "discount", rule=UNIT, sweep=True)
    lr: float = setting(0.00025, "learning rate of dqn.optimizer", rule=POSITIVE, sweep=True)
    lr_decay: bool = setting(
        False,
        "the learning rate falls linearly to 0 over the run's gradient steps (needs total_steps)",
    )
    rms_decay: float = setting(0.9, "RMSprop rho", rule=UNIT_OPEN, sweep=True)
    rms_eps: float = setting(1e-6, "RMSprop epsilon", rule=POSITIVE, sweep=True)
    batch_size: int = setting(64, "transitions per gradient step", rule=AT_LEAST_1)
    buffer_size: int = setting(
        1_000_000, "replay capacity, capped at the run's largest step count", rule=AT_LEAST_1
    )
    learning_starts: int = setting(
        64, "stored transitions before the first gradient step", rule=AT_LEAST_1, sweep=True
    )
    hidden: tuple[int, ...] = setting(
        (64, 64),
        "hidden layer widths",
        rule=WIDTHS,
    )
    scan_conv: tuple[int, ...] = setting(
        (),
        "channels of circular convolutions over the scan's beams before the hidden layers "
        "(kernel 5 beams, stride 2; the scan and each earlier scan or change are the "
        "input channels; needs env.observation normalised); empty: none (paper)",
        rule=CHANNELS,
    )
    dropout: float = setting(0.2, "dropout after the hidden layers", rule=UNIT_OPEN, sweep=True)
    # "periodic": hard copy every target_update_every env steps (paper).
    # "episode_end": online net gives the targets for the first target_update_every
    # steps, then the target net is synced at every episode end (ROBOTIS code).
    target_update: str = setting(
        PRESETS["paper"].target_update,
        "periodic (paper) or episode_end (ROBOTIS)",
        rule=one_of("periodic", "episode_end"),
    )
    target_update_every: int = setting(
        2000,
        "env steps between target syncs (warm-up for episode_end)",
        rule=AT_LEAST_1,
        sweep=True,
    )
    # Agent variants beyond the paper, all off by default (the paper's agent):
    double: bool = setting(
        False,
        "double DQN: the online net picks the next action, the target net values it",
        sweep=True,
    )
    dueling: bool = setting(False, "dueling head: Q = V + A - mean(A)")
    tau: float = setting(
        1.0,
        "Polyak target rate per step; 1: a copy every target_update_every steps (paper)",
        rule=(lambda v: 0.0 < v <= 1.0, "must be in (0, 1]"),
        sweep=True,
    )
    loss: str = setting(
        "mse", "TD loss: mse (paper) or huber (delta 1)", rule=one_of("mse", "huber"), sweep=True
    )
    optimizer: str = setting(
        "rmsprop",
        "rmsprop (paper, rms_decay and rms_eps), adam or radam (optax defaults)",
        rule=one_of("rmsprop", "adam", "radam"),
    )
    n_step: int = setting(
        1, "n-step returns: up to n rewards, then gamma^k bootstrap (1: paper)", rule=AT_LEAST_1
    )
    prioritised: bool = setting(
        False, "prioritised replay (Schaul et al. 2016, proportional); off: uniform (paper)"
    )
    per_alpha: float = setting(
        0.6, "prioritised replay: a slot's priority is (|TD error| + per_eps)^alpha", rule=UNIT
    )
    per_beta: float = setting(
        0.4,
        "prioritised replay: importance-weight exponent, annealed from this to 1 over the run",
        rule=UNIT,
    )
    per_eps: float = setting(
        1e-6, "prioritised replay: added to |TD error| so no slot's priority is 0", rule=POSITIVE
    )


# The DQN settings of the replay memory and the target network: PQN has neither, so
# a PQN config that sets one of them away from its default is refused.
REPLAY_ONLY = (
    "batch_size",
    "buffer_size",
    "learning_starts",
    "target_update",
    "target_update_every",
    "double",
    "tau",
    "n_step",
    "prioritised",
    "per_alpha",
    "per_beta",
    "per_eps",
)
# The settings prioritised replay reads: they need dqn.prioritised.
PRIORITISED_ONLY = ("per_alpha", "per_beta", "per_eps")


@dataclass(frozen=True)
class PQNConfig:
    """PQN (Gallici et al. 2024), read when agent is pqn; it shares dqn.gamma, lr,
    hidden, dropout, dueling, loss and optimizer with DQN."""

    num_envs: int = setting(16, "environments each run steps in parallel", rule=AT_LEAST_1)
    rollout: int = setting(32, "steps of every environment between updates (T)", rule=AT_LEAST_1)
    td_lambda: float = setting(0.65, "lambda of the lambda-returns", rule=UNIT)
    epochs: int = setting(2, "passes over each rollout", rule=AT_LEAST_1)
    minibatches: int = setting(
        4, "minibatches per pass (must divide num_envs x rollout)", rule=AT_LEAST_1
    )
    max_grad_norm: float = setting(10.0, "gradients clipped to this global norm", rule=POSITIVE)
    level_replay: float = setting(
        0.0,
        "level replay over the bank of drawn layouts (env.maze_bank): the share of new "
        "layouts picked from those the policy can just solve (the pqn.level_top share of "
        "the bank with the highest p (1 - p), p each layout's recent success in training); "
        "the rest uniformly. 0: every layout picked uniformly (jaxnav.agent.levels)",
        rule=UNIT,
    )
    level_top: float = setting(
        0.1,
        "level replay: the share of the bank's layouts it picks from (of the highest p (1 - p))",
        rule=(lambda v: 0.0 < v <= 1.0, "must be in (0, 1]"),
    )
    level_halflife: int = setting(
        409_600,
        "level replay: env steps (all the run's environments together) over which a "
        "layout's record of attempts and successes decays by half",
        rule=AT_LEAST_1,
    )


@dataclass(frozen=True)
class SACConfig:
    """SAC (Haarnoja et al. 2018, automatic entropy temperature), read when agent is
    sac; it needs env.actions continuous and explores by sampling its own policy
    (strategies [policy])."""

    num_envs: int = setting(16, "environments each run steps in parallel", rule=AT_LEAST_1)
    gamma: float = setting(0.99, "discount", rule=UNIT)
    lr: float = setting(
        1e-3, "Adam's learning rate of the actor, critics and temperature", rule=POSITIVE
    )
    lr_decay: bool = setting(
        False,
        "the actor's and critics' learning rates fall linearly to 0 over their gradient "
        "steps in the run's budget (needs total_steps); the temperature's does not",
    )
    batch_size: int = setting(128, "transitions per gradient step", rule=AT_LEAST_1)
    buffer_size: int = setting(
        200_000, "replay capacity, transitions (capped at the run's env steps)", rule=AT_LEAST_1
    )
    learning_starts: int = setting(
        4096,
        "env steps (all environments together) of uniform random actions before learning",
        rule=AT_LEAST_1,
    )
    updates: int = setting(
        2, "gradient steps after each step of all num_envs environments", rule=AT_LEAST_1
    )
    actor_every: int = setting(
        1,
        "the actor and the temperature step after every actor_every-th of the critics' "
        "gradient steps (TD3's delayed policy update), the critics and their targets after "
        "each; must divide sac.updates",
        rule=AT_LEAST_1,
    )
    n_step: int = setting(
        1,
        "steps of reward before the critics' target bootstraps: each sampled transition "
        "adds its environment's next ones, discounted, up to the episode's end (1: "
        "one-step targets)",
        rule=AT_LEAST_1,
    )
    tau: float = setting(
        0.005, "Polyak rate of the target critics per gradient step", rule=UNIT_OPEN
    )
    hidden: tuple[int, ...] = setting(
        (128, 128),
        "hidden layer widths of the actor and each critic",
        rule=WIDTHS,
    )
    layer_norm: bool = setting(True, "LayerNorm before each hidden ReLU of the critics")
    scan_conv: tuple[int, ...] = setting(
        (),
        "channels of circular convolutions over the scan's beams before the actor's and "
        "each critic's hidden layers, as dqn.scan_conv (needs env.observation "
        "normalised); empty: none",
        rule=CHANNELS,
    )
    shared_torso: bool = setting(
        False,
        "with sac.scan_conv: one set of scan convolutions, trained by the critics' loss, "
        "read by both critics and the actor (the actor's gradient stops at its output; "
        "the target critics keep their Polyak copy), as DrQ shares its encoder; off: the "
        "actor and each critic their own",
    )
    actor_average: float = setting(
        0.0,
        "Polyak rate of the tested actor: after each gradient step a copy of the actor's "
        "parameters moves this far towards them, and the copy is what is evaluated, tested "
        "and exported (0: the actor itself)",
        rule=UNIT_OPEN,
    )
    init_alpha: float = setting(0.1, "the entropy temperature at the start", rule=POSITIVE)
    entropy_scale: float = setting(
        1.0,
        "the entropy target is -entropy_scale x the action's size (2)",
        rule=(lambda v: v > 0, "must be positive: the entropy target is -scale x 2"),
    )
