"""Pnet's training pairs for the data modules' and LightningModules' tests."""

import numpy as np


def _pair_data(n=2000, n_ws=12, cloud_dim=120, seed=0):
    rng = np.random.default_rng(seed)
    clouds = rng.uniform(-20, 20, (n_ws, cloud_dim)).astype(np.float32)
    ws = rng.integers(0, n_ws, n)
    x_t = rng.uniform(-20, 20, (n, 2))
    x_goal = rng.uniform(-20, 20, (n, 2))
    shift = clouds[ws, :2] * 0.1  # depends on the workspace a little
    x_next = x_t + 0.3 * (x_goal - x_t) + shift
    return clouds, ws, x_t, x_goal, x_next
