"""`python -m harness.perf [perf=default|tiny] [perf.envs=[...]] [out=DIR]`: every speed
figure of the benchmark in one run, written to OUT/perf.md, OUT/perf.csv and
OUT/figures/perf_growth.png (machine, date and git revision in the header).

Trained networks and test sets come from the cache and are built first when missing
(that build is not part of any figure). Times move by 10-20% between runs on a shared
machine, so the report leads with ratios: MPNet / BIT*, step / floor, 2 workers / 1.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from harness.core.threads import single_threaded

single_threaded()  # before numpy, scipy, torch or numba load (harness.core.threads)

import hydra  # noqa: E402
from omegaconf import DictConfig, OmegaConf  # noqa: E402

from harness.core.cli import run_hydra  # noqa: E402


def _sizes(names) -> dict:
    """Network sizes of conf/scale/<name>.yaml: {name: {latent, pnet_hidden, enet_hidden}}."""
    conf = Path(__file__).resolve().parents[2] / "conf" / "scale"
    out = {}
    for n in names:
        m = OmegaConf.load(conf / f"{n}.yaml").model
        out[str(n)] = {"latent": m.latent, "pnet_hidden": list(m.pnet_hidden), "enet_hidden": list(m.enet_hidden)}
    return out


def _step(name: str, t0: float) -> None:
    print(f"perf: {name} done ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)


@hydra.main(version_base="1.3", config_path="../../conf", config_name="perf_main")
def main(cfg: DictConfig) -> None:
    from harness.core.kernels import use_kernel_cache
    from harness.core.provenance import machine_info
    from harness.core.settings import EnvSettings
    from harness.perf import render, sections
    from harness.perf.batched import batched
    from harness.perf.crossing import crossing
    from harness.perf.obstacles import obstacles
    from harness.perf.planners import planners

    use_kernel_cache(cfg.cache_dir)  # the jobs it starts inherit the place (harness.core.kernels)
    p = cfg.perf
    t0 = time.perf_counter()
    common = [
        f"scale={p.scale}",
        f"seed={p.seed}",
        f"budget_s={p.budget_s}",
        f"splits=[{','.join(p.splits)}]",
        f"cache_dir={cfg.cache_dir}",
        "progress=false",
    ]
    rows, errors = planners(list(p.envs), list(p.planners), common)
    _step("planners", t0)
    more, bad = batched(list(p.envs), str(p.batched.planner), common)
    rows, errors = rows + more, errors + bad
    _step("batched", t0)
    o = p.obstacles
    more, bad = obstacles(list(o.counts), list(o.planners), common, int(o.workspaces), int(o.queries), int(p.seed))
    rows, errors = rows + more, errors + bad
    _step("obstacles", t0)
    rows += sections.networks(_sizes(p.network_sizes), 2, 2800, int(p.network_repeats), int(p.network_inner))
    _step("networks", t0)
    rows += sections.checkers(list(p.envs), int(p.checker_workspaces))
    _step("checkers", t0)
    rows += crossing(list(p.envs), int(p.checker_workspaces))
    _step("crossing", t0)
    env_cfg = OmegaConf.load(Path(__file__).resolve().parents[2] / "conf" / "env" / f"{p.data.env}.yaml")
    env = EnvSettings.of(env_cfg)
    rows += sections.data_generation(env, int(p.data.workspaces), int(p.data.paths), tuple(p.data.jobs))
    _step("data", t0)
    rows += sections.training(_sizes(p.network_sizes), 2, int(p.training.batch), int(p.training.steps))
    _step("training", t0)
    out = Path(cfg.out)
    info = {**machine_info(), "perf": p.get("name", ""), "seconds": time.perf_counter() - t0}
    written = render.write(out, rows, errors, info, OmegaConf.to_container(p, resolve=True))
    for f in written:
        print(f)
    for e in errors:
        print(f"error: {e}", file=sys.stderr)
    if errors:
        sys.exit(1)


if __name__ == "__main__":
    run_hydra(main, required=(), optional=("perf",))
