"""Episode accounting, shared by the trainer and the test rollout.

:class:`Episodes` keeps a ring of finished episodes (return, length, goals, whether
it ended in a collision, mean exploration) and the running sums of the episode being
played. One call per environment step, :meth:`Episodes.record`, adds the step and,
where the episode ended, files it at a slot (an out-of-range slot drops it). With
several environments (PQN) the running sums are one per environment and one call
files every environment's finished episode at its own slot.
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

    @classmethod
    def zeros(cls, slots: int, envs: int | None = None) -> Episodes:
        """No episodes yet; ``envs``: running sums for that many environments (each
        argument of :meth:`record` then f32[envs] or i32[envs])."""
        cur = () if envs is None else (envs,)
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
        )

    def record(
        self,
        slot: chex.Array,
        reward: chex.Array,
        goal_reached: chex.Array,
        terminated: chex.Array,
        done: chex.Array,
        explore: chex.Array = 0.0,
    ) -> Episodes:
        """Add one step (its reward, whether it reached a goal, its exploration);
        where the episode is ``done``, file it at ``slot`` (i32[]; ``slots`` or more:
        not filed) and start the next. ``terminated``: it ended in a collision. With
        several environments every argument has one entry per environment, and the
        slots of the environments that file must differ."""
        cur_return = self.cur_return + reward
        cur_length = self.cur_length + 1
        cur_goals = self.cur_goals + goal_reached.astype(jnp.int32)
        cur_explore = self.cur_explore + explore
        i = slot
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
        )
