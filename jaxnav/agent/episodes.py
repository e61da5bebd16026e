"""Episode accounting, shared by the trainer and the test rollout.

:class:`Episodes` keeps a ring of finished episodes (return, length, goals, whether
it ended in a collision, mean exploration) and the running sums of the episode being
played. One call per environment step, :meth:`Episodes.record`, adds the step and,
where the episode ended, files it at a slot (an out-of-range slot drops it). With
several environments (PQN) the running sums are one per environment and one call
files every environment's finished episode at its own slot.

With an attempt limit (``env.attempt_limit``) it also counts how each episode's goal
attempts ended, by the rule of :mod:`jaxnav.report.navigation`: successes, collisions
and time-outs within the limit, and whether the last attempt was cut by the episode's
end. Without one these fields are None (no leaves) and the counts follow from the
episode's goals, collision and length (:func:`jaxnav.report.training.outcomes`).
"""

from __future__ import annotations

import chex
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class Episodes:
    """Finished episodes (``slots`` of them) and the running sums of the current one.
    Field names are part of the checkpoint layout (the trainer's ``metrics``)."""

    ep_return: chex.Array  # f32[slots]
    ep_length: chex.Array  # i32[slots]
    ep_goals: chex.Array  # i32[slots]
    ep_collided: chex.Array  # bool[slots]
    ep_explore: chex.Array  # f32[slots] mean H or eps over the episode
    cur_return: chex.Array  # f32[] (f32[envs] with several environments)
    cur_length: chex.Array  # i32[]
    cur_goals: chex.Array  # i32[]
    cur_explore: chex.Array  # f32[] sum over the episode
    # With an attempt limit: each episode's attempts that succeeded, collided or timed
    # out within it, and its last attempt cut (i32[slots] each); the current attempt's
    # steps and the current episode's counts so far (i32[], or i32[envs]).
    ep_successes: chex.Array | None = None
    ep_collisions: chex.Array | None = None
    ep_timeouts: chex.Array | None = None
    ep_cut: chex.Array | None = None
    cur_age: chex.Array | None = None
    cur_successes: chex.Array | None = None
    cur_timeouts: chex.Array | None = None

    @classmethod
    def zeros(cls, slots: int, envs: int | None = None, attempts: bool = False) -> Episodes:
        """No episodes yet; ``envs``: running sums for that many environments (each
        argument of :meth:`record` then f32[envs] or i32[envs]); ``attempts``: count
        the attempts' ends (an attempt limit is set)."""
        cur = () if envs is None else (envs,)
        counts = {}
        if attempts:
            counts = {f: jnp.zeros(slots, jnp.int32) for f in _EP_ATTEMPTS}
            counts |= {f: jnp.zeros(cur, jnp.int32) for f in _CUR_ATTEMPTS}
        return cls(
            ep_return=jnp.zeros(slots, jnp.float32),
            ep_length=jnp.zeros(slots, jnp.int32),
            ep_goals=jnp.zeros(slots, jnp.int32),
            ep_collided=jnp.zeros(slots, bool),
            ep_explore=jnp.zeros(slots, jnp.float32),
            cur_return=jnp.zeros(cur, jnp.float32),
            cur_length=jnp.zeros(cur, jnp.int32),
            cur_goals=jnp.zeros(cur, jnp.int32),
            cur_explore=jnp.zeros(cur, jnp.float32),
            **counts,
        )

    def record(
        self,
        slot: chex.Array,
        reward: chex.Array,
        goal_reached: chex.Array,
        terminated: chex.Array,
        done: chex.Array,
        explore: chex.Array = 0.0,
        limit: int = 0,
    ) -> Episodes:
        """Add one step (its reward, whether it reached a goal, its exploration);
        where the episode is ``done``, file it at ``slot`` (i32[]; ``slots`` or more:
        not filed) and start the next. ``terminated``: it ended in a collision. With
        several environments every argument has one entry per environment, and the
        slots of the environments that file must differ. ``limit``: the attempt limit
        in steps, read when the attempts' ends are counted."""
        cur_return = self.cur_return + reward
        cur_length = self.cur_length + 1
        cur_goals = self.cur_goals + goal_reached.astype(jnp.int32)
        cur_explore = self.cur_explore + explore
        i = slot
        counts = {}
        if self.cur_age is not None:
            counts = self._attempts(i, goal_reached, terminated, done, limit)
        return Episodes(
            ep_return=self.ep_return.at[i].set(cur_return, mode="drop"),
            ep_length=self.ep_length.at[i].set(cur_length, mode="drop"),
            ep_goals=self.ep_goals.at[i].set(cur_goals, mode="drop"),
            ep_collided=self.ep_collided.at[i].set(terminated, mode="drop"),
            ep_explore=self.ep_explore.at[i].set(cur_explore / cur_length, mode="drop"),
            cur_return=jnp.where(done, 0.0, cur_return),
            cur_length=jnp.where(done, 0, cur_length),
            cur_goals=jnp.where(done, 0, cur_goals),
            cur_explore=jnp.where(done, 0.0, cur_explore),
            **counts,
        )

    def _attempts(self, i, reached, terminated, done, limit: int) -> dict[str, chex.Array]:
        """The attempt counts after one step (the rule of jaxnav.report.navigation): a
        success or a collision within the limit, a time-out at the step that uses the
        limit up, a cut where the episode ends before it."""
        age = self.cur_age + 1
        within = age <= limit
        successes = self.cur_successes + (reached & within).astype(jnp.int32)
        timeouts = self.cur_timeouts + ((age == limit) & ~reached & ~terminated).astype(jnp.int32)
        collision = (terminated & within).astype(jnp.int32)
        cut = (done & ~terminated & ~reached & (age < limit)).astype(jnp.int32)
        return dict(
            ep_successes=self.ep_successes.at[i].set(successes, mode="drop"),
            ep_collisions=self.ep_collisions.at[i].set(collision, mode="drop"),
            ep_timeouts=self.ep_timeouts.at[i].set(timeouts, mode="drop"),
            ep_cut=self.ep_cut.at[i].set(cut, mode="drop"),
            cur_age=jnp.where(reached | done, 0, age),
            cur_successes=jnp.where(done, 0, successes),
            cur_timeouts=jnp.where(done, 0, timeouts),
        )


_EP_ATTEMPTS = ("ep_successes", "ep_collisions", "ep_timeouts", "ep_cut")
_CUR_ATTEMPTS = ("cur_age", "cur_successes", "cur_timeouts")
