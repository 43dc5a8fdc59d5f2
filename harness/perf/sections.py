"""The measurements of `python -m harness.perf` that need no bench run: the networks
against their BLAS floor, collision checking throughput, data generation and training
throughput. Each returns a list of flat rows (dicts) for perf.csv."""

from __future__ import annotations

import statistics
import time
from types import SimpleNamespace

import numpy as np

from harness.bench_checkers import bench_checker
from mpnet.envs.specs import get_spec
from mpnet.jit import njit
from mpnet.models.enet_kernel import EnetKernel
from mpnet.models.networks import Enet, Normalizer, Pnet, enet_numpy, pnet_numpy
from mpnet.models.pnet_kernel import PnetKernel, pnet_step


def _best_per_call(fn, repeats: int, inner: int) -> tuple[float, float]:
    """Median and p90 of the per-call time over `repeats` batches of `inner` calls."""
    for _ in range(inner):
        fn()
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(inner):
            fn()
        ts.append((time.perf_counter() - t) / inner)
    return statistics.median(ts), float(np.percentile(ts, 90))


def _floor(weights: list[np.ndarray], h0: np.ndarray):
    """The same weights as plain chained BLAS matmuls: what a step cannot beat."""

    def run():
        h = h0
        for w in weights:
            h = h @ w
        return h

    return run


@njit(cache=True)
def _steps(n, z, x, g, *args):
    """n compiled Pnet steps in a compiled loop: the step as the compiled planner calls it,
    without Python's call into numba."""
    for _ in range(n):
        pnet_step(z, x, g, *args)


def networks(sizes: dict, state_dim: int, cloud_dim: int, repeats: int, inner: int) -> list[dict]:
    """Pnet's step at batch 1 (dropout on, as MPNet plans; the numpy export, the compiled step
    called from Python, and the compiled step in a compiled loop, as the compiled planner runs
    it) and Enet's encoding of one cloud (numpy, compiled), each against its floor, at every
    size of `sizes`
    ({name: {"latent", "pnet_hidden", "enet_hidden"}})."""
    import torch

    rows = []
    rng = np.random.default_rng(0)
    for name, s in sizes.items():
        torch.manual_seed(0)
        latent = int(s["latent"])
        pnet = Pnet(latent + 2 * state_dim, state_dim, list(s["pnet_hidden"])).eval()
        pnet = pnet_numpy(pnet, Normalizer.points(state_dim))  # raw states in and out, as MPNet plans
        kernel = PnetKernel(pnet)
        z, x, g = np.zeros(latent, np.float32), np.zeros(state_dim), np.ones(state_dim)
        floor = _best_per_call(_floor(pnet.weights, np.zeros(pnet.in_dim, np.float32)), repeats, inner)
        for what, f in (("pnet_step", pnet.step), ("pnet_step_compiled", kernel.step)):
            step = _best_per_call(lambda f=f, z=z, x=x, g=g: f(z, x, g, rng), repeats, inner)
            rows.append(_net_row(what, name, pnet.in_dim, step, floor))
        out = np.empty(state_dim)
        loop = _best_per_call(
            lambda k=kernel, z=z, x=x, g=g, o=out: _steps(inner, z, x, g, *k.args, rng, True, k.buffers, o), repeats, 1
        )
        rows.append(_net_row("pnet_step_in_loop", name, pnet.in_dim, (loop[0] / inner, loop[1] / inner), floor))
        enet = enet_numpy(Enet(cloud_dim, list(s["enet_hidden"]), latent).eval(), Normalizer.points(2))
        cloud = rng.random(cloud_dim).astype(np.float32)
        floor = _best_per_call(_floor(enet.weights, cloud), repeats, max(1, inner // 10))
        for what, f in (("enet_encode", enet.encode), ("enet_encode_compiled", EnetKernel(enet).encode)):
            enc = _best_per_call(lambda f=f, cloud=cloud: f(cloud), repeats, max(1, inner // 10))
            rows.append(_net_row(what, name, cloud_dim, enc, floor))
    return rows


def _net_row(what: str, size: str, in_dim: int, t: tuple, floor: tuple) -> dict:
    return {
        "section": "networks",
        "what": what,
        "size": size,
        "in_dim": in_dim,
        "median_s": t[0],
        "p90_s": t[1],
        "floor_median_s": floor[0],
        "ratio_to_floor": t[0] / floor[0],
    }


def checkers(envs: list[str], workspaces: int) -> list[dict]:
    """Each env's checkers (every backend): states/s and motions/s one at a time, and in
    batches through the vectorised calls."""
    rows = []
    for env in envs:
        spec = get_spec(env)
        for backend in dict.fromkeys(spec.robot.checkers):
            r = bench_checker(spec, backend, workspaces)
            rows.append(
                {
                    "section": "checkers",
                    "env": env,
                    "backend": backend,
                    "states_per_s": r["states_per_s"][0],
                    "motions_per_s": r["motions_per_s"][0],
                    "states_per_s_batched": r["states_per_s_batched"][0],
                    "motions_per_s_batched": r["motions_per_s_batched"][0],
                    "configurations_per_s": r.get("configurations_per_s", (float("nan"),))[0],
                }
            )
    return rows


def data_generation(env, workspaces: int, paths: int, jobs: tuple[int, ...]) -> list[dict]:
    """Expert paths per second of the data stage (the expert as the env's settings say, spawned
    worker processes, chunked as the data stage chunks them) with each number of workers; env
    is an harness.core.settings.EnvSettings."""
    from harness.core.settings import data_params
    from mpnet.data.dataset import expert_paths_of

    spec = env.spec
    p = data_params(env, SimpleNamespace(workspaces=workspaces, paths=paths, ae_workspaces=0))
    train = [spec.generator.make(i, "train", env.data_seed) for i in range(workspaces)]
    rows = []
    for j in jobs:
        t = time.perf_counter()
        n = len(expert_paths_of(spec, p, train, jobs=j))
        dt = time.perf_counter() - t
        rows.append({"section": "data", "env": spec.name, "jobs": j, "paths": n, "seconds": dt, "paths_per_s": n / dt})
    return rows


def training(sizes: dict, state_dim: int, batch: int, steps: int) -> list[dict]:
    """Pnet training throughput (Adagrad, MSE, the paper's batch; samples/s) per size, on
    this machine's CPU with torch's own threads."""
    import torch

    rows = []
    for name, s in sizes.items():
        torch.manual_seed(0)
        latent = int(s["latent"])
        pnet = Pnet(latent + 2 * state_dim, state_dim, list(s["pnet_hidden"])).train()
        opt = torch.optim.Adagrad(pnet.parameters(), lr=0.01)
        x, y = torch.randn(batch, pnet.in_dim), torch.randn(batch, state_dim)

        def one(opt=opt, pnet=pnet, x=x, y=y):
            opt.zero_grad(set_to_none=True)
            torch.nn.functional.mse_loss(pnet(x), y).backward()
            opt.step()

        med, _ = _best_per_call(one, steps, 1)
        rows.append(
            {
                "section": "training",
                "size": name,
                "batch": batch,
                "threads": torch.get_num_threads(),
                "step_median_s": med,
                "samples_per_s": batch / med,
            }
        )
    return rows
