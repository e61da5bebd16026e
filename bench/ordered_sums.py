"""Bias gradients summed in one fixed order: does a run's arithmetic stop depending
on how many runs share the batch, and what does that cost? (Not used by jaxnav.)

A bias gradient is a sum over the sampled batch. XLA's CPU back end picks how to take
it from the whole array's shape, runs included (for the output layer's bias at the
paper's batch of 64: YNNPACK's reduction at 16 or more runs per device, a tree of
``reduce-window`` ops at 8 or fewer), so a run alone and among others sums in two orders
(``batch_width.py``). Here ``flax.linen.Dense`` is swapped, in this process only, for
:class:`Dense`, the same layer whose bias gradient :func:`ordered_sum` takes as
elementwise adds in one order: rows in blocks of 16, each block four groups of four
rows, every level summed left to right. Elementwise adds cannot be reordered by
vectorisation, so the sum is the same at any width.

    python bench/ordered_sums.py                    # widths 1 2 4 8 16 24 of 32 runs
    python bench/ordered_sums.py --runs 16 --widths 1 2 4 8 --set dqn.batch_size=16
    python bench/ordered_sums.py --time             # the learner alone, both ways
    python bench/ordered_sums.py --probe            # ordered_sum against x.sum(0) alone
    python bench/ordered_sums.py --train            # whole trainings: 4 runs alone, in 32
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import subprocess
import sys
from collections.abc import Callable

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp
from common import cores, device_env

# one CPU device, as batch_width.py (read when the backend starts, not at import)
os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=1")

BLOCK, GROUP = 16, 4


def _in_turn(parts):
    total = parts[0]
    for part in parts[1:]:
        total = total + part
    return total


def ordered_sum(x: chex.Array) -> chex.Array:
    """``x.sum(0)`` for ``f32[B, ...]`` in the order above; whole blocks side by side
    (``[B // 16, 4, 4, ...]`` sliced and added), a partial block row by row."""
    n = x.shape[0]
    whole = n // BLOCK * BLOCK
    blocks = []
    if whole:
        a = x[:whole].reshape((whole // BLOCK, BLOCK // GROUP, GROUP) + x.shape[1:])
        groups = _in_turn([a[:, :, i] for i in range(GROUP)])
        blocks = list(_in_turn([groups[:, i] for i in range(BLOCK // GROUP)]))
    if whole < n:
        rest = x[whole:]
        blocks.append(
            _in_turn([_in_turn(list(rest[g : g + GROUP])) for g in range(0, len(rest), GROUP)])
        )
    return _in_turn(blocks)


@jax.custom_vjp
def add_bias(y, bias):
    return y + jnp.reshape(bias, (1,) * (y.ndim - 1) + (-1,))


def _fwd(y, bias):
    return add_bias(y, bias), None


def _bwd(_, g):
    return g, ordered_sum(g.reshape((-1, g.shape[-1])))


add_bias.defvjp(_fwd, _bwd)


class Dense(nn.Module):
    """``flax.linen.Dense`` in float32 (same parameter names and initialisers, same
    forward pass) with the bias added by :func:`add_bias`."""

    features: int
    kernel_init: Callable = nn.initializers.lecun_normal()

    @nn.compact
    def __call__(self, inputs):
        kernel = self.param("kernel", self.kernel_init, (inputs.shape[-1], self.features))
        bias = self.param("bias", nn.initializers.zeros_init(), (self.features,))
        y = jax.lax.dot_general(inputs, kernel, (((inputs.ndim - 1,), (0,)), ((), ())))
        return add_bias(y, bias)


@contextlib.contextmanager
def ordered(on: bool = True):
    """``jaxnav.dqn.QNetwork`` builds :class:`Dense` layers while this is open."""
    saved = nn.Dense
    if on:
        nn.Dense = Dense
    try:
        yield
    finally:
        nn.Dense = saved


def timed(runs: int, beams: int, steps: int, reps: int, rounds: int) -> None:
    """The learner alone (``roofline.py``'s, ``runs`` runs of EBE), default and ordered
    taking turns, each in its own process on one device per core."""
    rates: dict[str, list[float]] = {"default": [], "ordered": []}
    for _ in range(rounds):
        for kind in rates:
            case = f"{runs},{beams},{steps},{reps},{int(kind == 'ordered')}"
            out = subprocess.run(
                [sys.executable, __file__, "--case", case],
                capture_output=True,
                text=True,
                env=device_env(cores()),
                check=True,
            )
            res = json.loads(out.stdout.strip().splitlines()[-1])
            assert res["runs"] == runs, res
            rates[kind].append(res["steps_per_s"])
    print(f"# the learner alone, {runs} runs, {beams} beams, {steps} steps, median of {reps}")
    print("| bias gradients | gradient steps/s, each round | median | ms per step |")
    print("|---|---|--:|--:|")
    for kind, r in rates.items():
        med = statistics.median(r)
        each = ", ".join(f"{x:,.0f}" for x in r)
        print(f"| {kind} | {each} | {med:,.0f} | {runs / med * 1e3:.3f} |")
    ratio = statistics.median(rates["ordered"]) / statistics.median(rates["default"])
    print(f"ordered / default: {ratio:.3f}")


def probe() -> None:
    """:func:`ordered_sum` against XLA's ``x.sum(0)``, each vmapped over R runs and
    compiled alone, on ``f32[R, B, H]`` of spread-out magnitudes: which kernel XLA
    picks, and whether the two agree bit for bit."""
    import numpy as np

    shapes = [(32, 64, 5), (32, 64, 64), (2, 64, 64), (8, 64, 5), (64, 64, 5), (32, 8, 64)]
    shapes += [(32, 16, 5), (32, 20, 64), (32, 40, 5), (32, 48, 5), (32, 128, 5), (32, 256, 64)]
    rng = np.random.default_rng(0)
    print("| R, B, H | XLA's kernel | ordered_sum = XLA's sum |")
    print("|---|---|---|")
    for shape in shapes:
        x = rng.standard_normal(shape) * np.exp(3 * rng.standard_normal(shape))
        x = x.astype(np.float32)
        xla = jax.jit(jax.vmap(lambda a: a.sum(0)))
        text = xla.lower(x).compile().as_text()
        kernel = (
            "YNNPACK" if "ynn" in text else "reduce-window" if "reduce-window" in text else "loop"
        )
        same = np.array_equal(np.asarray(xla(x)), np.asarray(jax.jit(jax.vmap(ordered_sum))(x)))
        print(f"| {', '.join(map(str, shape))} | {kernel} | {'yes' if same else 'no'} |")


def train_alone_and_among(episodes: int = 6) -> None:
    """The paper config trained for ``episodes`` with seeds=2 (4 runs) and seeds=16
    (32 runs) on one device, with XLA's sums and with ordered ones: are the 4 shared
    runs' parameters, metrics.csv and explore.csv the same?"""
    import csv
    import tempfile

    import numpy as np

    def rows(path, seeds):
        with open(path) as f:
            return [r for r in csv.reader(f) if r[1] in ("seed", *map(str, range(seeds)))]

    with tempfile.TemporaryDirectory() as tmp:
        for on in (False, True):
            for seeds in (2, 16):
                out = f"{tmp}/{int(on)}-{seeds}"
                case = f"train,{int(on)},{seeds},{episodes},{out}"
                cmd = [sys.executable, __file__, "--case", case]
                subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            a, b = f"{tmp}/{int(on)}-2", f"{tmp}/{int(on)}-16"
            pa, pb = np.load(f"{a}/params.npz"), np.load(f"{b}/params.npz")
            differ = sum(not np.array_equal(pa[k], pb[k]) for k in pa.files)
            same = {
                n: rows(f"{a}/{n}", 2) == rows(f"{b}/{n}", 2)
                for n in ("metrics.csv", "explore.csv")
            }
            print(
                f"{'ordered' if on else 'XLA'} sums: {differ} of {len(pa.files)} parameter arrays "
                f"differ; metrics.csv {'same' if same['metrics.csv'] else 'differs'}; "
                f"explore.csv {'same' if same['explore.csv'] else 'differs'}"
            )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=32)
    ap.add_argument("--widths", type=int, nargs="+", default=[1, 2, 4, 8, 16, 24])
    ap.add_argument("--set", nargs="*", default=[], help="config overrides (key=value)")
    ap.add_argument("--time", action="store_true", help="time the learner alone both ways")
    ap.add_argument("--learner-runs", type=int, default=64, help="with --time")
    ap.add_argument("--steps", type=int, default=2000, help="with --time")
    ap.add_argument("--rounds", type=int, default=3, help="with --time")
    ap.add_argument("--probe", action="store_true", help="ordered_sum against XLA's sum alone")
    ap.add_argument("--train", action="store_true", help="whole trainings, 4 runs alone and in 32")
    ap.add_argument("--case", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.case and args.case.startswith("train,"):
        _, on, seeds, episodes, out = args.case.split(",")
        with ordered(on == "1"):
            from jaxnav import train

            config = ["paper_no_obstacles", f"seeds={seeds}", f"episodes={episodes}"]
            return train.main([*config, "--out", out, "--quiet", "--yes"])
    if args.case:
        import roofline

        runs, beams, steps, reps, on = map(int, args.case.split(","))
        with ordered(bool(on)):  # EBE only: the seeds are the runs
            print(json.dumps(roofline.learner_alone(runs, beams, steps, reps)))
        return 0
    if args.probe:
        probe()
        return 0
    if args.train:
        train_alone_and_among()
        return 0
    if args.time:
        timed(args.learner_runs, 24, args.steps, 3, args.rounds)
        return 0
    import batch_width

    for on in (False, True):
        print(f"\n## bias gradients: {'ordered' if on else 'as XLA takes them'}")
        with ordered(on):
            batch_width.main(
                ["--runs", str(args.runs), "--widths", *map(str, args.widths), "--set", *args.set]
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
