"""`python -m harness.perf.torch_speed [--device cpu|cuda] [--out FILE]`: Pnet inference and
training throughput on one torch device, at the quick and the paper network sizes.

Measures, per size: one Pnet step (dropout on, as MPNet plans) at batch 1 and batched,
under `torch.inference_mode`; on the CPU also the numpy export the planner uses (its
floor); and training throughput (Adagrad, MSE, samples/s) at the paper's batch of 100
and a larger one. Prints and writes JSON, so a GPU machine's figures can be set beside
this CPU's (nothing in the project depends on a GPU).
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time

import numpy as np
import torch

from harness.core.provenance import machine_info
from mpnet.models.networks import ENET_LATENT, Pnet, paper_s2d, pnet_numpy

SIZES = {  # (latent, hidden) of conf/scale/quick.yaml and of the paper's s2D Pnet
    "quick": (28, (512, 256, 128, 64)),
    "paper": (ENET_LATENT, None),
}


def _pnet(size: str, state_dim: int = 2) -> Pnet:
    latent, hidden = SIZES[size]
    if hidden is None:
        return paper_s2d()[2]
    return Pnet(latent + 2 * state_dim, state_dim, hidden)


def _timed(fn, sync, repeats: int) -> list[float]:
    for _ in range(max(3, repeats // 10)):
        fn()
    sync()
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        sync()
        out.append(time.perf_counter() - t0)
    return out


def _summary(ts: list[float]) -> dict:
    return {"median_s": statistics.median(ts), "p90_s": float(np.percentile(ts, 90)), "n": len(ts)}


def inference(size: str, device: torch.device, sync, batches=(1, 64, 1024), repeats: int = 300) -> dict:
    pnet = _pnet(size).to(device).eval()
    out = {}
    with torch.inference_mode():
        for b in batches:
            x = torch.randn(b, pnet.in_dim, device=device)
            out[f"torch_batch{b}"] = _summary(_timed(lambda x=x: pnet(x, stochastic=True), sync, repeats))
    if device.type == "cpu":
        step = pnet_numpy(pnet.cpu())
        rng = np.random.default_rng(0)
        zd = step.in_dim - 2 * step.state_dim
        z, x, g = np.zeros(zd, np.float32), np.zeros(step.state_dim), np.ones(step.state_dim)
        out["numpy_batch1"] = _summary(_timed(lambda: step(z, x, g, rng), lambda: None, repeats))
    return out


def training(size: str, device: torch.device, sync, batches=(100, 1024), steps: int = 60) -> dict:
    out = {}
    for b in batches:
        torch.manual_seed(0)
        pnet = _pnet(size).to(device).train()
        opt = torch.optim.Adagrad(pnet.parameters(), lr=0.01)
        x = torch.randn(b, pnet.in_dim, device=device)
        y = torch.randn(b, pnet.out_dim, device=device)

        def step(pnet=pnet, opt=opt, x=x, y=y):
            opt.zero_grad(set_to_none=True)
            loss = torch.nn.functional.mse_loss(pnet(x), y)
            loss.backward()
            opt.step()

        ts = _timed(step, sync, steps)
        out[f"batch{b}"] = {**_summary(ts), "samples_per_s": b / statistics.median(ts)}
    return out


def measure(device_name: str) -> dict:
    device = torch.device(device_name)
    sync = torch.cuda.synchronize if device.type == "cuda" else (lambda: None)
    if device.type == "cpu":
        torch.set_num_threads(max(1, torch.get_num_threads()))
    name = torch.cuda.get_device_name(device) if device.type == "cuda" else platform.processor() or platform.machine()
    return {
        "device": device_name,
        "device_name": name,
        "torch": torch.__version__,
        "threads": torch.get_num_threads(),
        "sizes": {
            s: {
                "parameters": sum(p.numel() for p in _pnet(s).parameters()),
                "inference": inference(s, device, sync),
                "training": training(s, device, sync),
            }
            for s in SIZES
        },
    }


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    ap.add_argument("--out", help="also write the JSON here")
    args = ap.parse_args(argv)
    res = {**measure(args.device), "machine": machine_info()}  # revision, date, CPU: where it came from
    text = json.dumps(res, indent=2)
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
