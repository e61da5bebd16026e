"""No timing: whether a run computes the same floats in a smaller batch of runs.

Moving finished runs out of the compiled batch (compaction) would keep every run's
numbers only if a run's arithmetic does not depend on how many runs share the batch.
This script checks that on the trainer's own pieces: it trains ``--runs`` runs of the
paper config (one CPU device, ``jaxnav.train``'s chunk) past the start of learning,
then, for the whole batch and for its first ``W`` runs alone, computes one gradient
step of every run on the same sampled batch (``jaxnav.dqn``'s loss, vmapped as the
trainer vmaps it) and prints, per width, which of the loss, the Q-values and each
gradient leaf are bit for bit the same for those runs.

    python bench/batch_width.py                        # 32 runs; widths 2 4 8 16 24
    python bench/batch_width.py --runs 32 --widths 8 16 --set dqn.batch_size=16
"""

from __future__ import annotations

import argparse
import functools
import os
import sys

os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=1")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=32, help="runs of the whole batch (even)")
    ap.add_argument("--widths", type=int, nargs="+", default=[2, 4, 8, 16, 24])
    ap.add_argument("--set", nargs="*", default=[], help="config overrides (key=value)")
    args = ap.parse_args(argv)

    import jax
    import numpy as np

    from jaxnav import dqn
    from jaxnav.agent import replay
    from jaxnav.core.config import load_config
    from jaxnav.run.training import Run

    cfg = load_config(
        None, [f"seeds={args.runs // 2}", "episodes=50", "run.chunk_steps=300", *args.set]
    )
    run = Run(cfg, None, quiet=True)
    ts = run.fresh_state()
    ts, _ = run.chunk(ts, np.int32(300))  # past dqn.learning_starts
    network = dqn.network_of(cfg, run.trainer.env)

    def one(t):
        k_sample, k_drop = jax.random.split(jax.random.PRNGKey(0))
        batch = replay.sample(t.buffer, k_sample, cfg.dqn.batch_size)
        loss_fn = functools.partial(dqn._loss, network, t.hyper)
        loss, grads = jax.value_and_grad(loss_fn)(t.params, t.target_params, batch, k_drop)
        return loss, network.apply(t.params, batch.obs), grads

    step = jax.jit(jax.vmap(one))
    whole = jax.tree.map(np.asarray, step(ts))
    leaves, _ = jax.tree_util.tree_flatten_with_path(whole[2])
    names = ["loss", "Q"] + ["grad " + jax.tree_util.keystr(p[1:]) for p, _ in leaves]
    print(f"# {args.runs} runs, batch {cfg.dqn.batch_size}; same floats as in the whole batch:")
    print("| runs in the batch | " + " | ".join(names) + " |")
    print("|--:|" + "---|" * len(names))
    for w in args.widths:
        first = functools.partial(lambda a, n: a[:n], n=w)
        part = jax.tree.map(np.asarray, step(jax.tree.map(first, ts)))
        same = [
            np.array_equal(a[:w], b) for a, b in zip(jax.tree.leaves(whole), jax.tree.leaves(part))
        ]
        # tree order: loss, Q, then the gradient leaves
        print(f"| {w} | " + " | ".join("same" if s else "differs" for s in same) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
