"""The circular convolutions over the scan (dqn.scan_conv): against a brute-force loop,
the NumPy twin the robot runs, the observation's layout, and the settings' refusals."""

from __future__ import annotations

import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxnav.agent.networks import CircularConv, QNetwork, ScanTorso, split_scans
from jaxnav.core.config import load_config
from jaxnav.env import from_config
from jaxnav.robot.scan import circular_conv, scan_torso


def conv_by_loops(x: np.ndarray, kernel: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """One circular convolution, kernel 5, stride 2, ReLU, output by output and tap by
    tap: out[o, f] = relu(bias[f] + sum_t sum_c x[(2 o + t - 2) mod w, c] kernel[t, c, f])."""
    width, channels = x.shape
    taps, _, features = kernel.shape
    out = np.zeros(((width + 1) // 2, features))
    for o in range(out.shape[0]):
        for f in range(features):
            total = float(bias[f])
            for t in range(taps):
                beam = (2 * o + t - 2) % width
                for c in range(channels):
                    total += float(x[beam, c]) * float(kernel[t, c, f])
            out[o, f] = max(total, 0.0)
    return out


@pytest.mark.parametrize("width, channels", [(24, 4), (12, 16), (3, 2), (1, 1)])
def test_the_convolution_equals_a_loop_over_outputs_and_taps(width, channels):
    """The flax layer (one matrix product) and the robot's NumPy twin both equal the
    loop, a narrow layer included, where two taps wrap onto one beam."""
    rng = np.random.default_rng(width)
    x = rng.normal(size=(width, channels)).astype(np.float32)
    layer = CircularConv(6)
    params = layer.init(jax.random.key(0), jnp.asarray(x))
    kernel = np.asarray(params["params"]["kernel"])
    bias = rng.normal(size=6).astype(np.float32)  # the init's zeros would hide a bias bug
    params = {"params": {"kernel": jnp.asarray(kernel), "bias": jnp.asarray(bias)}}
    want = conv_by_loops(x, kernel, bias)
    assert kernel.shape == (5, channels, 6)
    np.testing.assert_allclose(np.asarray(layer.apply(params, jnp.asarray(x))), want, atol=1e-5)
    np.testing.assert_allclose(circular_conv(x, kernel, bias), want, atol=1e-12)


def test_turning_the_scan_by_two_beams_moves_the_outputs_by_one():
    """The scan wraps round the robot: rolling every channel by the stride rolls the
    layer's outputs by one position, the first beam next to the last."""
    rng = np.random.default_rng(1)
    x = rng.normal(size=(2, 24, 3)).astype(np.float32)
    layer = CircularConv(5)
    params = layer.init(jax.random.key(1), jnp.asarray(x))
    y = np.asarray(layer.apply(params, jnp.asarray(x)))
    rolled = np.asarray(layer.apply(params, jnp.asarray(np.roll(x, 2, axis=1))))
    np.testing.assert_allclose(rolled, np.roll(y, 1, axis=1), atol=1e-5)
    assert not np.allclose(y, np.roll(y, 1, axis=1))  # the test can tell them apart


def test_the_torso_reads_the_scan_and_its_history_where_the_observation_holds_them():
    """On an environment with a scan history, the torso's channels are the observation's
    scan and each history block, and its other values come after them in their order."""
    cfg = load_config(
        None,
        [
            "preset=modern",
            "env.maze=stage4",
            "env.scan_history=3",
            "env.history_changes=true",
            "dqn.scan_conv=[8,4]",
        ],
    )
    env, params = from_config(cfg)
    beams, gap, history = env.scan_layout
    assert (beams, gap, history) == (24, 4, 3)
    obs = np.arange(env.obs_size, dtype=np.float32)  # each value its own index
    scans, rest = split_scans(jnp.asarray(obs), env.scan_layout)
    scans = np.asarray(scans)
    np.testing.assert_array_equal(scans[:, 0], obs[:beams])  # the scan
    for k in range(history):  # the k-th earlier scan's changes, newest first
        start = beams + gap + k * beams
        np.testing.assert_array_equal(scans[:, 1 + k], obs[start : start + beams])
    np.testing.assert_array_equal(np.asarray(rest), obs[beams : beams + gap])
    # the network, through its torso, and the robot's NumPy twin agree on real observations
    net = QNetwork(
        env.num_actions, (32,), 0.0, layer_norm=True, scan_conv=(8, 4), scan_layout=env.scan_layout
    )
    real = np.asarray(env.reset(jax.random.key(3), params)[0])[None]
    p = net.init(jax.random.key(2), jnp.asarray(real))
    torso = p["params"]["ScanTorso"]
    convs = [(np.asarray(torso[n]["kernel"]), np.asarray(torso[n]["bias"])) for n in torso]
    got = scan_torso(real, convs, env.scan_layout)
    want = ScanTorso((8, 4), env.scan_layout).apply({"params": torso}, jnp.asarray(real))
    assert got.shape == (1, 6 * 4 + 4)  # 24 beams -> 12 -> 6 outputs of 4 channels
    np.testing.assert_allclose(got, np.asarray(want), atol=1e-5)


def test_the_paper_network_has_no_torso():
    """Without dqn.scan_conv (every preset's default) the network is the paper's MLP."""
    for preset in ("paper", "modern"):
        cfg = load_config(None, [f"preset={preset}"])
        assert cfg.dqn.scan_conv == ()
    net = QNetwork(5, (64, 64), 0.2)
    p = net.init(jax.random.key(0), jnp.zeros(26))
    assert "ScanTorso" not in p["params"]


@pytest.mark.parametrize(
    "extra, says",
    [
        (["env.observation=robotis", "dqn.scan_conv=[16]"], "needs env.observation normalised"),
        (["preset=modern", "dqn.scan_conv=[16,0]"], "positive channel counts"),
        (["preset=modern", "dqn.scan_conv=16"], "dqn.scan_conv"),
    ],
    ids=["robotis_observation", "zero_channels", "not_a_list"],
)
def test_a_scan_convolution_that_cannot_be_built_is_one_line_and_exit_2(tmp_path, extra, says):
    r = subprocess.run(
        [sys.executable, "-m", "jaxnav", "train", "smoke", *extra, "--out", str(tmp_path / "r")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and says in lines[0] and "Traceback" not in r.stderr
