"""perf.md, perf.csv and the cost-growth figure from the rows of one perf run."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from harness.report.names import PLANNER_LABELS, env_label
from harness.report.render import _md_table
from harness.report.tables import LOADED
from mpnet.envs.specs import get_spec

SPLIT = (  # (label, share column(s)): MPNet's time split, disjoint
    ("cloud", "cloud_s_share"),
    ("Enet", ("encode_s_share", "cloud_s_share")),
    ("Pnet", "pnet_s_share"),
    ("steerTo", "steer_s_share"),
    ("feasibility", "feasible_s_share"),
    ("contraction", "contract_s_share"),
    ("replanning", "replan_s_share"),
    ("fallback", "fallback_s_share"),
)


def _g(x, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return "—"
    return f"{x:.{digits}g}"


def _ms(x) -> str:
    return _g(x * 1e3) if x is not None and np.isfinite(x) else "—"


def _pct(x) -> str:
    return f"{x * 100:.1f}" if x is not None and np.isfinite(x) else "—"


def _share(r: pd.Series, col) -> float:
    if isinstance(col, tuple):
        return r[col[0]] - r[col[1]]
    return r[col]


PERF_LABELS = {
    **PLANNER_LABELS,
    "mpnet_nr_numpy": "MPNet (NR), numpy loop",
    "mpnet_hr_numpy": "MPNet (HR), numpy loop",
}


OMPL_PLANNERS = ("bit_star", "informed_rrt_star", "rrt_star", "rrt_connect")  # their checks cross into Python


def planner_label(p: str) -> str:
    return PERF_LABELS.get(p, p)


def planners_md(pl: pd.DataFrame) -> str:
    bit = {r.env: r for r in pl.itertuples() if r.planner == "bit_star"}
    head = [
        "Env",
        "Planner",
        "Queries",
        "Success [%]",
        "time_s median / p90 [ms]",
        "plan_s median / p90 [ms]",
        "time_s / BIT*",
        "plan_s / BIT*",
        "Checks (median)",
        "Configurations (median)",
        "CPU share",
    ]
    rows = []
    for r in pl.itertuples():
        b = bit.get(r.env)
        share = getattr(r, "cpu_share", float("nan"))
        waited = " (waited)" if share < LOADED else ""
        rows.append(
            [
                env_label(r.env),
                planner_label(r.planner),
                str(int(r.queries)),
                _pct(r.success_rate),
                f"{_ms(r.time_median_s)} / {_ms(r.time_p90_s)}",
                f"{_ms(r.plan_median_s)} / {_ms(r.plan_p90_s)}",
                _g(r.time_median_s / b.time_median_s) if b is not None else "—",
                _g(r.plan_median_s / b.time_median_s) if b is not None else "—",
                _g(r.checks_median),
                _g(getattr(r, "configurations_median", float("nan"))),
                f"{_pct(share)}{waited}",
            ]
        )
    return _md_table(head, rows)


def split_md(pl: pd.DataFrame) -> str:
    if "cloud_s_share" not in pl:
        return "No MPNet planner ran."
    mp = pl[pl["cloud_s_share"].notna()]
    head = ["Env", "Planner"] + [label for label, _ in SPLIT] + ["other"]
    rows = []
    for _, r in mp.iterrows():
        shares = [_share(r, c) for _, c in SPLIT]
        rows.append(
            [env_label(r["env"]), planner_label(r["planner"])]
            + [_pct(s) for s in shares]
            + [_pct(1 - float(np.nansum(shares)))]
        )
    return _md_table(head, rows)


def overhead_md(pl: pd.DataFrame) -> str:
    head = [
        "Env",
        "Planner",
        "Harness / planning, median [%]",
        "p90 [%]",
        "Log process CPU per query [ms]",
        "Peak RSS planning / log [MB]",
    ]
    rows = [
        [
            env_label(r.env),
            planner_label(r.planner),
            _pct(r.overhead_median),
            _pct(r.overhead_p90),
            _ms(r.log_cpu_per_query_s),
            f"{r.rss_planning_mb:.0f} / {r.rss_log_mb:.0f}",
        ]
        for r in pl.itertuples()
    ]
    return _md_table(head, rows)


def growth(pl: pd.DataFrame) -> pd.DataFrame:
    """Median time and checks per query against the state dimension, per planner."""
    g = pl[["env", "planner", "time_median_s", "plan_median_s", "checks_median"]].copy()
    g["state_dim"] = [get_spec(e).state_dim for e in g["env"]]
    return g.sort_values(["planner", "state_dim", "env"])


def cost_figure(df: pd.DataFrame, x: str, xlabel: str, title: str, path: Path, annotate: str | None = None) -> None:
    """Median time and checks per query against `x`, one line per planner (log axes);
    `annotate`: a column whose value labels each point."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 4), layout="tight")
    axes = fig.subplots(1, 2)
    for p, d in df.groupby("planner", sort=False):
        for ax, col in zip(axes, ("time_median_s", "checks_median")):
            ax.plot(d[x], d[col], marker="o", label=planner_label(p))
            if annotate is not None:
                for xv, y, e in zip(d[x], d[col], d[annotate]):
                    ax.annotate(e, (xv, y), fontsize=6, alpha=0.6)
    axes[0].set_ylabel("median time per solved query [s] (time_s)")
    axes[1].set_ylabel("median collision checks per query")
    for ax in axes:
        ax.set_xlabel(xlabel)
        ax.set_yscale("log")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)


def gpu_md(folder: Path) -> str:
    """The GPU figures of `python -m harness.perf.torch_speed` runs kept in folder, quoted."""
    files = sorted(folder.glob("*.json")) if folder.is_dir() else []
    rows = []
    for f in files:
        d = json.loads(f.read_text())
        for size, s in d.get("sizes", {}).items():
            inf, tr = s.get("inference", {}), s.get("training", {})
            b1 = inf.get("torch_batch1", {}).get("median_s")
            big = inf.get("torch_batch1024", {}).get("median_s")
            t100 = tr.get("batch100", {}).get("samples_per_s")
            rows.append([f.name, d.get("device_name", ""), size, _ms(b1), _ms(big), _g(t100 if t100 else float("nan"))])
    if not rows:
        return "No GPU measurement is kept (no GPU machine was available)."
    head = ["File", "Device", "Size", "Pnet batch 1 [ms]", "Pnet batch 1024 [ms]", "Training batch 100 [samples/s]"]
    return _md_table(head, rows)


def crossing_md(cx: pd.DataFrame, pl: pd.DataFrame | None) -> list[str]:
    """The price of a check compiled and through OMPL's callbacks, and (with the planners' runs)
    about how much of each OMPL planner's median time its checks' crossings are."""
    rows_ = [
        [env_label(r.env), r.check, _g(r.compiled_us), _g(r.python_us), _g(r.ompl_us), _g(r.crossing_us)]
        for r in cx.itertuples()
    ]
    parts = [
        "",
        "## The price of a check: compiled, and through OMPL's callbacks into Python",
        "",
        _md_table(["Env", "Check", "Compiled [µs]", "From Python [µs]", "Through OMPL [µs]", "Crossing [µs]"], rows_),
        "",
        "The same random states, and motions from a free state toward another cut to the planner range, checked "
        "in a compiled loop (what MPNet's compiled loop and `rrt_connect_compiled` pay), from Python through the "
        "checker, and through OMPL's validity callback and motion validator (what every OMPL planner pays, "
        "MPNet-HR's RRT* included; a bare Python-to-OMPL call subtracted). Crossing: OMPL's price less the "
        "compiled one. Medians over repeats and workspaces. Where a check costs hundreds of microseconds (an "
        "arm's motion), the crossing is the difference of two large medians and moves by tens of microseconds "
        "between runs: read it as an order of magnitude there.",
    ]
    if pl is None or "state_checks_median" not in pl:
        return parts
    price = {(r.env, r.check): r.crossing_us for r in cx.itertuples()}
    shares = []
    for r in pl.itertuples():
        if r.planner not in OMPL_PLANNERS or (r.env, "state") not in price:
            continue
        us = r.state_checks_median * price[(r.env, "state")] + r.motion_checks_median * price[(r.env, "motion")]
        shares.append([env_label(r.env), planner_label(r.planner), _ms(us * 1e-6), _ms(r.time_median_s),
                       _pct(us * 1e-6 / r.time_median_s)])  # fmt: skip
    if shares:
        parts += [
            "",
            _md_table(["Env", "OMPL planner", "Crossings [ms]", "time_s median [ms]", "Share [%]"], shares),
            "",
            "Crossings: the median query's state and motion checks times the crossing's price, over the median "
            "solved query's time (medians of different queries: an estimate). A time ratio between an OMPL "
            "planner and a compiled one carries this much plumbing; `rrt_connect_compiled` against `rrt_connect` "
            "measures it on one algorithm.",
        ]
    return parts


def write(out: Path, rows: list[dict], errors: list[str], info: dict, settings: dict) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    df = pd.DataFrame(rows)
    csv = out / "perf.csv"
    df.to_csv(csv, index=False)
    sec = {s: d.reset_index(drop=True) for s, d in df.groupby("section", sort=False)}
    parts = [
        "# Performance",
        "",
        f"Generated by `python -m harness.perf` on {info['date']}, git {info['git_rev']}, "
        f"{info['cpu']} ({info['cpus']} CPUs), {info['os']}, in {info['seconds'] / 60:.1f} min. "
        f"Settings: scale `{settings['scale']}`, splits {settings['splits']}, seed {settings['seed']}, "
        f"budget {settings['budget_s']} s. Times move by 10-20% between runs on a shared machine: "
        "read the ratios. Our classical planners are OMPL's C++; the paper's were Python.",
    ]
    files = [csv]
    if "planners" in sec:
        pl = sec["planners"]
        n = int(pl["queries"].max())
        parts += [
            "",
            "## Planners on the same queries",
            "",
            planners_md(pl),
            "",
            f"Each planner ran the same queries of an env (the {'/'.join(settings['splits'])} split of the "
            f"`{settings['scale']}` test set) in its own process, one run at a time. "
            "time_s: the query as if it were the first in its workspace (MPNet samples the point cloud and "
            "encodes it: Table I's time). plan_s: given the workspace's code (time_s less MPNet's cloud and "
            "Enet), as a robot that encodes its scene once would see it; for the classical planners plan_s = "
            "time_s. Medians and p90 over the solved queries; / BIT*: ratio of medians to BIT*'s time_s "
            "(its first solution). Checks: collision checks per query (states + motions, every query). "
            f"CPU share: the queries' CPU time over their wall time; under {LOADED:.0%} (marked waited) they "
            "waited for the CPU, and their times are the machine's, not the planner's.",
            "",
            "## Where MPNet's time goes [% of time_s]",
            "",
            split_md(pl),
            "",
            "Sum over the run's queries of each part's time, over the sum of time_s. cloud: sampling the "
            "workspace's point cloud; Enet: encoding it; Pnet: its steps; steerTo: NeuralPlanner's connection "
            "checks; feasibility: the whole-path checks; contraction: lazy states contraction; replanning: its "
            "own checks beside Pnet and steerTo; fallback: HR's classical planner; other: the rest "
            "(bookkeeping, endpoint checks).",
            "",
            "## Harness overhead and memory",
            "",
            overhead_md(pl),
            "",
            "Harness / planning: per query, the planning loop's own time around the planner (building the "
            "problem, bookkeeping, the hand-off to the log process) over the planner's time_s. The log process "
            "re-checks and writes each query beside the loop (its CPU per query). Peak RSS: the planning "
            "process and the log process of each run (VmHWM; a log process forked from the planning one: "
            "its peak less the pages it started with, shared with the planning process); a bench run's peak "
            "is at most their sum.",
        ]
        g = growth(pl)
        fig = out / "figures" / "perf_growth.png"
        title = f"How cost grows with dimension (same queries per env, n = {n})"
        cost_figure(g, "state_dim", "state dimension", title, fig, annotate="env")
        files.append(fig)
        head = ["Planner", "Env", "State dim", "time_s median [ms]", "plan_s median [ms]", "Checks (median)"]
        grows = [
            [planner_label(r.planner), env_label(r.env), str(r.state_dim), _ms(r.time_median_s),
             _ms(r.plan_median_s), _g(r.checks_median)]
            for r in g.itertuples()
        ]  # fmt: skip
        parts += [
            "",
            "## How cost grows with dimension",
            "",
            _md_table(head, grows),
            "",
            "![median time and checks against the state dimension](figures/perf_growth.png)",
        ]
    if "obstacles" in sec:
        ob = sec["obstacles"].sort_values(["planner", "blocks"], kind="stable")
        fig = out / "figures" / "perf_obstacles.png"
        title = f"How cost grows with the number of obstacles (n = {int(ob['queries'].max())} queries per count)"
        cost_figure(ob, "blocks", "blocks in the workspace (s2d-like)", title, fig)
        files.append(fig)
        rows_ = [
            [planner_label(r.planner), str(int(r.blocks)), str(int(r.queries)), _pct(r.success_rate),
             _ms(r.time_median_s), _ms(r.plan_median_s), _g(r.checks_median)]
            for r in ob.itertuples()
        ]  # fmt: skip
        parts += [
            "",
            "## How cost grows with the number of obstacles",
            "",
            _md_table(
                [
                    "Planner",
                    "Blocks",
                    "Queries",
                    "Success [%]",
                    "time_s median [ms]",
                    "plan_s median [ms]",
                    "Checks (median)",
                ],
                rows_,
            ),  # fmt: skip
            "",
            "s2d-like layouts: N random 5 x 5 blocks in the s2d square, the same queries for every planner "
            "(problem files, `mpnet.envs.scenes.generators.RandomBlocks`). MPNet plans with the s2d networks, trained "
            "on 7 blocks: other counts are out of its training distribution (its cloud spreads the same "
            "1400 points over all blocks).",
            "",
            "![median time and checks against the number of blocks](figures/perf_obstacles.png)",
        ]
    if "batched" in sec:
        bt = sec["batched"]
        rows_ = [
            [env_label(r.env), planner_label(r.planner), r.mode, str(int(r.queries)), _g(r.batch_mean),
             _pct(r.success_rate), _g(r.queries_per_s), _ms(r.latency_median_s), _ms(r.latency_p90_s)]
            for r in bt.itertuples()
        ]  # fmt: skip
        head = ["Env", "Planner", "Mode", "Queries", "Queries per batch", "Success [%]", "Queries/s"]
        parts += [
            "",
            "## Batched planning: throughput and latency",
            "",
            _md_table([*head, "Latency median [ms]", "Latency p90 [ms]"], rows_),
            "",
            "The same queries (the runs' test set, each with its bench seed) planned by the compiled planner "
            "in one process: `one`, a query at a time (each samples and encodes its cloud); `batched`, a "
            "workspace's queries together (`mpnet.planners.compiled.batched`: one encoding per workspace, the first "
            "NeuralPlanner runs in lockstep with one Pnet product per step for all of them, then each query "
            "alone). A batched query's latency runs from its batch's start to its answer. Success: the "
            "planner's own feasibility check (the bench runs above are the ones re-checked); batched "
            "queries draw other dropout masks, so their success is measured, not assumed equal.",
        ]
    if "networks" in sec:
        nw = sec["networks"]
        rows_ = [
            [r.what, r.size, str(int(r.in_dim)), _g(r.median_s * 1e6), _g(r.p90_s * 1e6), _g(r.floor_median_s * 1e6),
             _g(r.ratio_to_floor)]
            for r in nw.itertuples()
        ]  # fmt: skip
        parts += [
            "",
            "## Networks against their floor (batch 1, one thread)",
            "",
            _md_table(["What", "Size", "Input", "Median [µs]", "p90 [µs]", "Floor [µs]", "Ratio"], rows_),
            "",
            "Pnet step: the planner's numpy export, the compiled step called from Python (`_compiled`) and "
            "in a compiled loop (`_in_loop`: as the default planner runs it, Python's call into numba left "
            "out), with dropout on (as MPNet plans), raw s2D states in and out. Floor: the same "
            "weights as plain chained BLAS matmuls (no bias, activation, dropout or scaling). Enet: one "
            "cloud of 1400 2-D points, numpy and compiled.",
        ]
    if "checkers" in sec:
        ck = sec["checkers"]
        rows_ = [
            [env_label(r.env), r.backend, f"{r.states_per_s:,.0f}", f"{r.states_per_s_batched:,.0f}",
             f"{r.motions_per_s:,.0f}", f"{r.motions_per_s_batched:,.0f}",
             f"{r.configurations_per_s:,.0f}" if np.isfinite(r.configurations_per_s) else "—"]
            for r in ck.itertuples()
        ]  # fmt: skip
        parts += [
            "",
            "## Collision checking throughput",
            "",
            _md_table(
                [
                    "Env",
                    "Checker",
                    "States/s",
                    "States/s batched",
                    "Motions/s",
                    "Motions/s batched",
                    "Configurations/s",
                ],
                rows_,
            ),  # fmt: skip
            "",
            "Single: one counted call per state or motion (random states; motions between random free "
            "states). Batched: one vectorised call for 2000 states or 200 motions. Medians over repeats.",
        ]
    if "crossing" in sec:
        parts += crossing_md(sec["crossing"], sec.get("planners"))
    if "data" in sec:
        dd = sec["data"]
        base = float(dd["paths_per_s"].iloc[0])
        rows_ = [
            [env_label(r.env), str(int(r.jobs)), str(int(r.paths)), _g(r.seconds), _g(r.paths_per_s),
             _g(r.paths_per_s / base)]
            for r in dd.itertuples()
        ]  # fmt: skip
        parts += [
            "",
            "## Data generation",
            "",
            _md_table(["Env", "Workers", "Paths", "Seconds", "Paths/s", "Speed-up"], rows_),
            "",
            "Expert paths (RRT*, the env's iterations) in spawned worker processes, process start-up included.",
        ]
    if "training" in sec:
        tr = sec["training"]
        rows_ = [[r.size, str(int(r.batch)), str(int(r.threads)), _g(r.samples_per_s)] for r in tr.itertuples()]
        parts += [
            "",
            "## Training throughput (CPU)",
            "",
            _md_table(["Size", "Batch", "Torch threads", "Samples/s"], rows_),
            "",
            "Pnet training steps (forward, MSE, backward, Adagrad) on random data, this machine's CPU.",
        ]
    parts += [
        "",
        "## GPU",
        "",
        gpu_md(Path(settings.get("gpu_results") or "")),
        "",
        "Measured by `python -m harness.perf.torch_speed --device cuda` on a GPU machine when one was lent; "
        "nothing in the project needs a GPU.",
    ]
    if errors:
        parts += ["", "## Runs that failed", ""] + [f"- {e}" for e in errors]
    md = out / "perf.md"
    md.write_text("\n".join(parts) + "\n")
    return [md, *files]
