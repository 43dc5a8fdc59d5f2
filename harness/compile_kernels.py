"""`python -m harness.compile_kernels [ENV ...] [--cache-dir DIR]`: numba's kernels compiled once,
into the on-disk kernel cache runs read (`DIR/kernels`, the runs' `cache_dir`, or `NUMBA_CACHE_DIR`
if set: harness.core.kernels), before runs need them.

A process that finds the cache cold compiles what it calls: about a minute for the arm's
checker and compiled MPNet loop, seconds for the planar envs. The processes of a parallel
sweep on a fresh install (a cluster array, joblib's workers, the test suite's workers) each
compile the same kernels at once; run this first and each of them loads them in about a second.

For each env (all of them by default): its default checker's four checks, the judge's fine
re-check, the workspace point cloud, the compiled RRT-Connect (`rrt_connect_compiled`), and
the compiled MPNet loop (batched planning's too) for
each network depth a scale gives the env, on untrained networks of that depth (their weights do
not matter to the compiler; Pnet's layers travel flat, so the loop compiles once for every
depth, and the other depths only load it: mpnet/models/pnet_kernel.py).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from harness.core.cli import CONF_DIR
from harness.core.kernels import use_kernel_cache
from mpnet.envs.spec import EnvSpec
from mpnet.envs.specs import SPECS, generated, get_spec
from mpnet.envs.workspace import Workspace
from mpnet.models.numpy_nets import EnetArrays, Normalizer, NumpyEnet, NumpyPnet, PnetArrays
from mpnet.motion import verify_path
from mpnet.planners.base import Problem
from mpnet.planners.compiled import batched
from mpnet.planners.compiled.rrt_connect import CompiledRRTConnect
from mpnet.planners.mpnet import MPNetSettings

WIDTH, LATENT, POINTS_PER_BLOCK = 8, 4, 20  # any sizes compile the same code


def network_depths(env: str) -> list[tuple[int, int]]:
    """(Enet's, Pnet's) hidden layer counts of each scale's networks for the env, as the composed
    configs give them (an env's own scale settings included), fewest Pnet layers first."""
    from hydra import compose, initialize_config_dir

    scales = sorted(p.stem for p in (CONF_DIR / "scale").glob("*.yaml"))
    depths = set()
    with initialize_config_dir(str(CONF_DIR), version_base="1.3"):
        for scale in scales:
            model = compose("config", [f"+env={env}", "+planner=mpnet_nr", f"scale={scale}"]).scale.model
            depths.add((len(model.enet_hidden), len(model.pnet_hidden)))
    return sorted(depths, key=lambda d: (d[1], d[0]))


def _prelu_stack(sizes: list[int], linear, act, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """A state dict of linear layers through `sizes`, a one-weight PReLU after each but the
    last; linear(i) and act(i) are layer i's key prefixes."""
    state = {}
    for i, (a, b) in enumerate(zip(sizes, sizes[1:])):
        state[f"{linear(i)}.weight"] = (0.1 * rng.standard_normal((b, a))).astype(np.float32)
        state[f"{linear(i)}.bias"] = np.zeros(b, np.float32)
        if i < len(sizes) - 2:
            state[f"{act(i)}.weight"] = np.full(1, 0.25, np.float32)
    return state


def untrained_networks(spec: EnvSpec, cloud_dim: int, depths: tuple[int, int], seed: int = 0):
    """(NumpyEnet, NumpyPnet) of these depths with random weights, normalisers as a checkpoint's
    (the layers' key names are EnetArrays' and PnetArrays')."""
    rng = np.random.default_rng(seed)
    (enet_depth, pnet_depth), sd = depths, spec.state_dim
    enet_sizes, pnet_sizes = [cloud_dim, *[WIDTH] * enet_depth, LATENT], [LATENT + 2 * sd, *[WIDTH] * pnet_depth, sd]
    enet_state = _prelu_stack(enet_sizes, lambda i: f"net.{2 * i}", lambda i: f"net.{2 * i + 1}", rng)
    pnet_state = _prelu_stack(pnet_sizes, lambda i: f"linears.{i}", lambda i: f"acts.{i}", rng)
    enet = EnetArrays({"hidden": [WIDTH] * enet_depth, "in_dim": cloud_dim}, enet_state)
    pnet = PnetArrays(
        {"hidden": [WIDTH] * pnet_depth, "in_dim": LATENT + 2 * sd, "out_dim": sd, "dropout": 0.5}, pnet_state
    )
    return NumpyEnet(enet, Normalizer(spec.workspace_scale())), NumpyPnet(pnet, Normalizer(spec.space.scale()))


def _no_obstacles(spec: EnvSpec) -> Workspace:
    d = spec.workspace_dim
    return Workspace("none", "file", np.zeros((0, d)), np.zeros((0, d)))


def compile_env(spec: EnvSpec, depths: list[tuple[int, int]]) -> None:
    """Every kernel a bench run of MPNet on this env calls, compiled or loaded from the cache (an env
    of problem files only: its checks and RRT-Connect's, on a workspace without obstacles)."""
    ws = spec.generator.make(0, "seen", 0) if spec.generator is not None else _no_obstacles(spec)
    rng = np.random.default_rng(0)
    start, goal = spec.space.sample(rng), spec.space.sample(rng)
    checker = spec.make_checker(ws)
    checker.warm_up(start)
    verify_path(spec, ws, [start.tolist(), goal.tolist()], start.tolist(), goal.tolist(), spec.validation_step)
    CompiledRRTConnect().warm_up(Problem(spec, ws, checker, start, goal, seed=0))
    if spec.generator is None:  # no networks for it
        return
    cloud = spec.cloud(ws, POINTS_PER_BLOCK, 0)
    settings = MPNetSettings(name="mpnet_nr", compiled=True)
    settings.check_env(spec)
    for d in depths:
        encode, pnet = untrained_networks(spec, cloud.size, d)
        planner = settings.assemble(encode, pnet, spec, 0, lambda _ws: cloud)
        batched.warm_up(planner, Problem(spec, ws, checker, start, goal, seed=0))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.compile_kernels", description=__doc__.split("\n\n")[0])
    ap.add_argument("envs", nargs="*", metavar="ENV", help=f"envs (default: all with a generator): {', '.join(SPECS)}")
    ap.add_argument("--cache-dir", default=".cache/mpnet-bench", help="the runs' cache_dir (default: %(default)s)")
    args = ap.parse_args(argv)
    use_kernel_cache(args.cache_dir)
    try:
        specs = [get_spec(e) for e in args.envs or generated()]
    except KeyError as e:
        print(f"error: {e.args[0]}", file=sys.stderr)
        return 2
    for spec in specs:
        t = time.perf_counter()
        depths = network_depths(spec.name) if spec.generator is not None else []  # no networks: no MPNet loop
        try:
            compile_env(spec, depths)
        except ValueError as e:  # a robot's files missing or broken (ArmModelError), said in one line
            print(f"error: {spec.name}: {e}", file=sys.stderr)
            return 2
        layers = ", ".join(str(p) for p in sorted({p for _, p in depths}))
        what = f"cloud, MPNet loop (Pnet of {layers} hidden layers)" if depths else "(problem files only: no networks)"
        print(f"{spec.name}: checks, re-check, RRT-Connect, {what}: {time.perf_counter() - t:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
