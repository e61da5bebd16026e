"""CPU peer: Stable-Baselines3's DQN (PyTorch) on jaxnav.interop.gym, against our trainer.

The same task and the same learner, the way most people would run it on a CPU:
SB3's DQN on the Gymnasium wrapper of our environment (``jaxnav.interop.gym``, one robot,
NumPy in and out), one gradient step per environment step.

Matched to ours (paper Table 2):

* network 64-64 ReLU, Dropout 0.2 before the 5 linear outputs (a small SB3 policy,
  :class:`DropoutDQNPolicy`; dropout on in gradient steps, off when acting and in
  the target net, as in Keras and in ours). PyTorch's default init, not
  lecun-uniform: no effect on speed.
* squared TD error: SB3 hard-codes the Huber loss; ``train`` is SB3's own, with
  ``F.smooth_l1_loss`` pointed at ``F.mse_loss`` for this process (same cost);
* RMSprop(lr 2.5e-4, alpha = rho = 0.9, eps 1e-6; PyTorch adds eps outside the sqrt,
  as optax ``eps_in_sqrt=False``), gamma 0.9, batch 64, ``learning_starts=64``,
  ``train_freq=1``, ``gradient_steps=1``, hard target copy every 2000 steps, the
  same replay capacity as ours; ``max_grad_norm`` at infinity (SB3 still runs its
  clip, a few microseconds);
* exploration: SB3 has only a linear epsilon schedule. It decays 1.0 -> 0.05 over
  the warm-up, so the timed segments run at eps 0.05 and the Q-network's forward
  pass runs on 95% of steps (SB3 skips it for random actions; ours is EBE, which
  needs it on every step). The paper's per-episode decay 0.99 matches a linear
  schedule over about 60% of a full 500 x 500-step run.

Threads: ``torch.set_num_threads(1)`` by default (``--threads``). At batch 64 and
64-wide layers a second intra-op thread costs more in synchronisation than it
gains, and the environment's XLA runtime has the second core. SB3 trains one seed
per process, so for many seeds a user runs one SB3 process per core: our 32-seed
figure is compared with that (``--parallel``, measured with the processes running at
once), our 1-seed figure with one process. Ours runs on one CPU device per core, as
``jaxnav train`` does.

Measured, in one run: SB3's transitions/s (median of ``--segments`` segments of
``--steps`` steps after ``--warmup`` steps, timed by a callback); the wrapper alone
with random actions (steps/s, same median), and so the share of SB3's time that is
the environment; our trainer at 1 and 32 seeds (bench/train_throughput.py, same
steps, capacity and beams).

    python bench/peers_sb3.py            # needs torch==2.13.0 (CPU) and stable-baselines3
    python bench/peers_sb3.py --quick
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time

from common import MARK, child_env, cores, machine, ours_train

PEER = "Stable-Baselines3 DQN (PyTorch CPU)"


def make_sb3(env, capacity: int, warmup: int, total: int, seed: int = 0):
    import torch
    from stable_baselines3 import DQN
    from stable_baselines3.common.logger import Logger
    from stable_baselines3.dqn import dqn as sb3_dqn
    from stable_baselines3.dqn.policies import DQNPolicy, QNetwork
    from torch import nn

    class DropoutQNetwork(QNetwork):
        """SB3's MLP Q-network with Dropout(0.2) after the second hidden layer."""

        def __init__(self, *args, dropout: float = 0.2, **kwargs):
            super().__init__(*args, **kwargs)
            layers = list(self.q_net)
            layers.insert(len(layers) - 1, nn.Dropout(dropout))
            self.q_net = nn.Sequential(*layers)

    class DropoutDQNPolicy(DQNPolicy):
        def make_q_net(self):
            net_args = self._update_features_extractor(self.net_args, features_extractor=None)
            return DropoutQNetwork(**net_args).to(self.device)

    class _F:  # torch.nn.functional with the Huber loss replaced by the squared error
        def __getattr__(self, name):
            return getattr(torch.nn.functional, name)

        smooth_l1_loss = staticmethod(torch.nn.functional.mse_loss)

    sb3_dqn.F = _F()
    model = DQN(
        DropoutDQNPolicy,
        env,
        learning_rate=2.5e-4,
        buffer_size=capacity,
        learning_starts=64,
        batch_size=64,
        gamma=0.9,
        train_freq=1,
        gradient_steps=1,
        target_update_interval=2000,
        exploration_initial_eps=1.0,
        exploration_final_eps=0.05,
        exploration_fraction=warmup / total,
        max_grad_norm=float("inf"),
        policy_kwargs=dict(
            net_arch=[64, 64],
            activation_fn=nn.ReLU,
            optimizer_class=torch.optim.RMSprop,
            optimizer_kwargs=dict(alpha=0.9, eps=1e-6),
        ),
        device="cpu",
        seed=seed,
        verbose=0,
    )
    model.set_logger(Logger(folder=None, output_formats=[]))  # no log folders in /tmp
    return model


def segment_rates(times: list[float], steps: int) -> list[float]:
    return [steps / (b - a) for a, b in zip(times, times[1:])]


def run_sb3(
    beams: int,
    steps: int,
    segments: int,
    warmup: int,
    capacity: int,
    threads: int,
    maze: str = "square4",
) -> dict:
    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    from jaxnav.interop.gym import NavGymEnv

    torch.set_num_threads(threads)
    total = warmup + segments * steps
    marks: list[float] = []

    class Clock(BaseCallback):
        def _on_step(self) -> bool:
            n = self.num_timesteps - warmup
            if n >= 0 and n % steps == 0:
                marks.append(time.perf_counter())
            return True

    env = NavGymEnv(maze, n_beams=beams)
    model = make_sb3(env, capacity, warmup, total)
    model.learn(total_timesteps=total, callback=Clock())
    rates = segment_rates(marks, steps)
    assert len(rates) == segments and model._n_updates == total - 64
    return {
        "transitions_per_s": statistics.median(rates),
        "segments": rates,
        "torch": torch.__version__,
        "threads": threads,
    }


def run_wrapper(beams: int, steps: int, segments: int, maze: str = "square4") -> dict:
    """The Gymnasium wrapper alone: random actions, reset after every episode end."""
    import numpy as np

    from jaxnav.interop.gym import NavGymEnv

    env = NavGymEnv(maze, n_beams=beams)
    rng = np.random.default_rng(0)
    env.reset(seed=0)

    def run(n):
        for a in rng.integers(0, env.action_space.n, n):
            _, _, terminated, truncated, _ = env.step(int(a))
            if terminated or truncated:
                env.reset()

    run(200)  # compile and warm up
    rates = []
    for _ in range(segments):
        t0 = time.perf_counter()
        run(steps)
        rates.append(steps / (time.perf_counter() - t0))
    return {"steps_per_s": statistics.median(rates), "segments": rates}


def run_sb3_parallel(
    n: int, beams: int, steps: int, segments: int, warmup: int, capacity: int, threads: int
) -> dict:
    """``n`` SB3 runs at once, one process each (seeds in parallel, one per core): the
    sum of their transitions/s."""
    cmd = [
        sys.executable,
        __file__,
        "--one-sb3",
        "--beams",
        str(beams),
        "--steps",
        str(steps),
        "--segments",
        str(segments),
        "--warmup",
        str(warmup),
        "--capacity",
        str(capacity),
        "--threads",
        str(threads),
    ]
    procs = [
        subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=child_env()
        )
        for _ in range(n)
    ]
    rates = []
    for p in procs:
        out, err = p.communicate(timeout=3600)
        lines = [x for x in out.splitlines() if x.startswith(MARK)]
        if p.returncode != 0 or not lines:
            raise RuntimeError(
                f"parallel SB3 run failed: {(err.strip().splitlines() or ['?'])[-1]}"
            )
        rates.append(json.loads(lines[-1][len(MARK) :])["transitions_per_s"])
    return {"processes": n, "transitions_per_s": sum(rates), "per_process": rates}


def measure(
    beams: int,
    steps: int,
    segments: int,
    warmup: int,
    capacity: int,
    threads: int,
    ours_seeds=(1, 32),
    reps: int = 3,
    parallel: int = 1,
    log=print,
) -> dict:
    """SB3 (one process, and ``parallel`` at once), the wrapper alone, and ours at
    ``ours_seeds``; one dict. Ours with one seed is compared with one SB3 process, ours
    with many seeds with SB3 running one seed per core."""
    sb3 = run_sb3(beams, steps, segments, warmup, capacity, threads)
    wrap = run_wrapper(beams, steps, segments)
    share = sb3["transitions_per_s"] / wrap["steps_per_s"]
    log(
        f"SB3 DQN: {sb3['transitions_per_s']:,.0f} transitions/s (torch {sb3['torch']}, "
        f"{threads} thread(s)); wrapper alone {wrap['steps_per_s']:,.0f} steps/s, "
        f"so the environment is {100 * share:.0f}% of SB3's time"
    )
    par = None
    if parallel > 1:
        par = run_sb3_parallel(parallel, beams, steps, segments, warmup, capacity, threads)
        log(
            f"SB3 DQN, {parallel} processes at once: {par['transitions_per_s']:,.0f} transitions/s "
            f"in all ({', '.join(f'{r:,.0f}' for r in par['per_process'])})"
        )
    res = {
        "beams": beams,
        "steps": steps,
        "capacity": capacity,
        "sb3": sb3,
        "sb3_parallel": par,
        "wrapper": wrap,
        "env_share": share,
        "ours": {},
    }
    for seeds in ours_seeds:
        o = ours_train(seeds, beams, steps, reps, capacity)["transitions_per_s"]
        res["ours"][seeds] = o
        peer = par if (par and seeds > 1) else sb3
        log(
            f"ours {seeds:>3} seeds: {o:,.0f} transitions/s, ours/SB3 "
            f"({peer.get('processes', 1)} process(es)) {o / peer['transitions_per_s']:.1f}x"
        )
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--beams", type=int, default=24)
    ap.add_argument(
        "--steps", type=int, default=2000, help="steps per timed segment (and per chunk of ours)"
    )
    ap.add_argument("--segments", type=int, default=5, help="timed segments (median)")
    ap.add_argument("--warmup", type=int, default=2000, help="untimed SB3 steps first")
    ap.add_argument("--reps", type=int, default=3, help="timed chunks of ours (median)")
    ap.add_argument("--capacity", type=int, default=250_000, help="replay capacity per seed")
    ap.add_argument("--threads", type=int, default=1, help="torch.set_num_threads")
    ap.add_argument(
        "--seeds",
        type=int,
        nargs="*",
        default=[1, 32],
        help="seeds of ours (none: SB3 and the wrapper only)",
    )
    ap.add_argument(
        "--parallel",
        type=int,
        default=cores(),
        help="SB3 processes at once for the many-seed comparison (default: one per core)",
    )
    ap.add_argument("--one-sb3", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--quick", action="store_true", help="500-step segments x 3, 20k capacity")
    ap.add_argument("--json", help="also write the results here")
    args = ap.parse_args(argv)
    if args.quick:
        args.steps, args.segments, args.warmup, args.reps, args.capacity = 500, 3, 500, 2, 20_000
    if args.one_sb3:  # child of run_sb3_parallel
        r = run_sb3(args.beams, args.steps, args.segments, args.warmup, args.capacity, args.threads)
        print(MARK + json.dumps(r), flush=True)
        return 0
    print(
        f"# SB3 DQN vs jaxnav trainer, square4, {args.beams} beams, segments of {args.steps} "
        f"steps, capacity {args.capacity}/seed; {machine()}",
        flush=True,
    )
    res = measure(
        args.beams,
        args.steps,
        args.segments,
        args.warmup,
        args.capacity,
        args.threads,
        args.seeds,
        args.reps,
        args.parallel,
    )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
