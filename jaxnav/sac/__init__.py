"""SAC, the continuous-action agent, in the trainer shape DQN and PQN share.

Soft actor-critic (Haarnoja et al. 2018, "Soft Actor-Critic Algorithms and
Applications": twin critics, target critics by Polyak averaging, automatic entropy
temperature) drives continuous commands (``env.actions continuous``: an action in
[-1, 1]^2 sets the speed across ``env.speed_range`` and the yaw rate across
+-``env.max_yaw_rate``). As in the fast recipes for parallel simulation (FastTD3 and
its SAC variant, 2025), each run steps ``sac.num_envs`` environments together and takes
``sac.updates`` gradient steps after each step of all of them, from a replay memory of
``sac.buffer_size`` transitions.

* The actor (:class:`Actor`) is a squashed Gaussian: a = tanh(u), u ~ N(mu, sigma), its
  log-probability with the tanh correction (:func:`squashed_sample`). Its mean action
  tanh(mu) is the policy that is tested, exported and deployed; exploring, it samples.
* The critics (:class:`TwinCritic`) fit the soft target
  y = r + gamma (1 - terminated) (min_i Q'_i(s', a') - alpha log pi(a' | s')),
  a' ~ pi(s') (:func:`soft_target`); a truncation bootstraps from its final observation.
* The actor minimises alpha log pi(a | s) - min_i Q_i(s, a); the temperature minimises
  -log(alpha) (log pi(a | s) + H_target) (:func:`temperature_loss`), H_target =
  -``sac.entropy_scale`` x 2.
* The first ``sac.learning_starts`` env steps act uniformly at random.
* Optional, each off by default: n-step targets (``sac.n_step``), the actor's and the
  temperature's step after every ``sac.actor_every``-th critic step (TD3's delay), the
  actor's and critics' learning rates falling linearly to 0 over the budget
  (``sac.lr_decay``), one scan torso for the actor and both critics
  (``sac.shared_torso``).
* With ``sac.actor_average`` > 0 the policy that is evaluated, tested and exported is a
  Polyak average of the actor's parameters, moved that far towards the actor after each
  gradient step; the actor that explores and learns is unchanged by it.

Counting is PQN's (docs/training.md): ``step`` is the env steps of all the run's
environments, ``episode`` the episodes any of them finished.

Modules: :mod:`~jaxnav.sac.networks` (the actor, the critics, the torso),
:mod:`~jaxnav.sac.learner` (the losses, the replay memory, one gradient step) and
:mod:`~jaxnav.sac.trainer` (the run). They import ``jaxnav.agent``, ``jaxnav.env`` and
``jaxnav.core``, and one another in that order.
"""

from jaxnav.sac.learner import (
    Learner,
    Memory,
    make_learner,
    n_step_returns,
    optimizers,
    soft_target,
    temperature_loss,
)
from jaxnav.sac.networks import (
    ACTION_SIZE,
    Actor,
    Critic,
    TwinCritic,
    critic_of,
    network_of,
    split_torso,
    squashed_sample,
    trained_part,
    with_torso,
)
from jaxnav.sac.trainer import SACState, make_trainer

__all__ = [
    "ACTION_SIZE",
    "Actor",
    "Critic",
    "Learner",
    "Memory",
    "SACState",
    "TwinCritic",
    "critic_of",
    "make_learner",
    "make_trainer",
    "n_step_returns",
    "network_of",
    "optimizers",
    "soft_target",
    "split_torso",
    "squashed_sample",
    "temperature_loss",
    "trained_part",
    "with_torso",
]
