"""`python -m harness.report.learning_curve DIR [DIR ...] [--out reports/learning_curve]`: how
MPNet grows with data. Each run's training-set size comes from its logged facts:
`scale.train.workspaces` × `scale.train.paths` asked, and the paths built where a run of that
env and size logged them (`training_paths_built`: panda_mbm's cage queries can fail, so its
datasets hold fewer than asked); per env × split × planner × size: success
with its Wilson interval, path quality (median cost / reference over successes), the share
of Pnet's proposals in collision and reachable from their tree end, and the workspace-code
sensitivity. A table (md, csv) and a figure against training paths on a log axis, beside the
random-proposal ablation and the paper's 97% (MPNet-NR, Table I's mean accuracy).

Kept apart from the main report, whose tables key on env × split × planner and would pool
the sizes."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from harness.report.facts import logged_facts
from harness.report.load import load, queries_frame
from harness.report.names import PAPER, env_label, env_rank, split_rank
from harness.report.readme import provenance
from harness.report.stats import wilson

PAPER_NR_SUCCESS = 0.97
COLUMNS = [
    "env",
    "split",
    "planner",
    "train_workspaces",
    "paths_per_workspace",
    "train_paths",
    "queries",
    "success",
    "success_ci_low",
    "success_ci_high",
    "quality_median",
    "in_collision",
    "reachable",
    "code_shift",
    "dropout_spread",
]


def train_size(run: dict) -> tuple[int, int] | None:
    """(training workspaces, paths per workspace) from a run's logged config."""
    facts = logged_facts(run)
    w, p = facts["train_workspaces"], facts["train_paths"]
    return (int(w), int(p)) if w and p else None


def learning_curve_table(files) -> tuple[pd.DataFrame, list[str]]:
    """One row per (env, split, planner, size), pooled over seeds; warnings for runs without a size."""
    warns = []
    sizes = {}
    for i, tf in enumerate(files):
        sizes[i] = train_size(tf.run)
        if sizes[i] is None:
            warns.append(f"warning: {tf.path}: its config gives no scale.train size: left out of the learning curve")
    q = queries_frame(files)
    if q.empty:
        return pd.DataFrame(columns=COLUMNS), warns
    q = q[q["file"].map(lambda i: sizes.get(i) is not None)].copy()
    q["train_workspaces"] = q["file"].map(lambda i: sizes[i][0])
    q["paths_per_workspace"] = q["file"].map(lambda i: sizes[i][1])
    diag = {}
    for i, tf in enumerate(files):
        for j, m in enumerate(tf.queries):
            d = m.get("diagnostics")
            if isinstance(d, dict):
                diag[(i, j)] = d
    built = {}  # (env, workspaces, paths per workspace) -> paths built, from any run that logged them
    for i, tf in enumerate(files):
        n = logged_facts(tf.run).get("training_paths_built")
        if sizes[i] is not None and isinstance(n, int):
            built[(tf.run.get("env"), *sizes[i])] = n
    rows = []
    for key, g in q.groupby(["env", "split", "planner", "train_workspaces", "paths_per_workspace"], sort=False):
        n, k = len(g), int(g["success"].sum())
        lo, hi = wilson(k, n)
        ok = g[g["success"] & (g["reference_cost"] > 0)]
        ds = [diag[(f, j)] for f, j in zip(g["file"], g["qidx"]) if (f, j) in diag]
        props = sum(d.get("proposals", 0) for d in ds)

        def share(name, ds=ds, props=props):
            return sum(d.get(name, 0) for d in ds) / props if props else math.nan

        def median(name, ds=ds):
            v = [d[name] for d in ds if isinstance(d.get(name), (int, float))]
            return float(np.median(v)) if v else math.nan

        rows.append(
            {
                "env": key[0],
                "split": key[1],
                "planner": key[2],
                "train_workspaces": key[3],
                "paths_per_workspace": key[4],
                "train_paths": built.get((key[0], key[3], key[4]), key[3] * key[4]),
                "queries": n,
                "success": k / n,
                "success_ci_low": lo,
                "success_ci_high": hi,
                "quality_median": float((ok["path_cost"] / ok["reference_cost"]).median()) if len(ok) else math.nan,
                "in_collision": share("proposals_in_collision"),
                "reachable": share("proposals_reachable"),
                "code_shift": median("code_shift"),
                "dropout_spread": median("dropout_spread"),
            }
        )
    df = pd.DataFrame(rows, columns=COLUMNS)
    df = df.sort_values(
        by=["env", "split", "planner", "train_paths", "train_workspaces"],
        key=lambda c: c.map(env_rank) if c.name == "env" else c.map(split_rank) if c.name == "split" else c,
    )
    return df.reset_index(drop=True), warns


def _pct(x) -> str:
    return "–" if x != x else f"{100 * x:.1f}"


def provenance_lines(files) -> list[str]:
    """Where the rows come from: the logs' revisions (a dirty tree marked), machines, dates."""
    prov = provenance(files)
    dirty = [r for r in prov["git_rev"] if r.endswith("-dirty")]
    lines = [
        f"From {len(files)} trial logs: git revision {', '.join(prov['git_rev'])}; machine {', '.join(prov['host'])}; "
        f"runs started between {prov['from']} and {prov['to']} (UTC).",
    ]
    if dirty:
        lines.append(f"**Some logs come from a dirty tree** ({', '.join(dirty)}): uncommitted code made them.")
    return lines


def render_learning_curve(df: pd.DataFrame, files=()) -> str:
    head = [
        "env",
        "split",
        "planner",
        "training paths (workspaces × paths asked)",
        "queries",
        "success % [95% CI]",
        "quality (median cost / ref.)",
        "proposals in collision %",
        "reachable %",
        "code shift / dropout spread (median)",
    ]
    lines = [
        "# MPNet against training-set size",
        "",
        f"Success with its Wilson 95% interval; the paper reports MPNet (NR) at about "
        f"{PAPER_NR_SUCCESS:.0%} on 100 × 4000 paths ({PAPER}). Quality: median path cost / reference over the "
        "solved queries. Proposal shares and code sensitivity from the `/query` diagnostics (see diagnostics.md).",
        "",
        *(provenance_lines(files) + [""] if files else []),
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for r in df.itertuples(index=False):
        shift = "–" if r.code_shift != r.code_shift else f"{r.code_shift:.3g} / {r.dropout_spread:.3g}"
        lines.append(
            "| "
            + " | ".join(
                [
                    r.env,
                    r.split,
                    r.planner,
                    f"{r.train_paths} ({r.train_workspaces} × {r.paths_per_workspace})",
                    str(r.queries),
                    f"{_pct(r.success)} [{_pct(r.success_ci_low)}, {_pct(r.success_ci_high)}]",
                    "–" if r.quality_median != r.quality_median else f"{r.quality_median:.3f}",
                    _pct(r.in_collision),
                    _pct(r.reachable),
                    shift,
                ]
            )
            + " |"
        )
    return "\n".join(lines) + "\n"


def figure(df: pd.DataFrame, out: Path) -> list[Path]:
    """Success (with intervals), quality and in-collision share against training paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    envs = sorted(df["env"].unique(), key=env_rank)
    cols = [("success", "success"), ("quality_median", "median cost / reference"), ("in_collision", "in collision")]
    fig, axes = plt.subplots(len(envs), 3, figsize=(13, 3.4 * len(envs)), squeeze=False)
    for r, env in enumerate(envs):
        e = df[df["env"] == env]
        for c, (col, label) in enumerate(cols):
            ax = axes[r][c]
            for (split, planner), g in e.groupby(["split", "planner"]):
                g = g.sort_values("train_paths")
                style = "-" if split == "seen" else "--"
                marker = "o" if planner == "mpnet_nr" else "x"
                y = g[col].to_numpy(float)
                if col == "success":
                    err = np.vstack([y - g["success_ci_low"], g["success_ci_high"] - y])
                    ax.errorbar(g["train_paths"], y, yerr=err, ls=style, marker=marker, label=f"{planner} {split}")
                else:
                    ax.plot(g["train_paths"], y, ls=style, marker=marker, label=f"{planner} {split}")
            if col == "success":
                ax.axhline(PAPER_NR_SUCCESS, color="gray", lw=0.8, ls=":", label="paper NR (97%)")
            ax.set_xscale("log")
            ax.set_xlabel("training paths")
            ax.set_ylabel(label)
            ax.set_title(f"{env_label(env)}: {label}")
            ax.grid(alpha=0.3)
        axes[r][0].legend(fontsize=7)
    fig.tight_layout()
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "learning_curve.png", out / "learning_curve.svg"]
    for p in paths:
        fig.savefig(p, dpi=120)
    plt.close(fig)
    return paths


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.report.learning_curve", description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+", metavar="DIR", help="directories searched recursively for trials.mcap")
    ap.add_argument("--out", default="reports/learning_curve", help="output directory")
    args = ap.parse_args(argv)
    files, warns, _ = load(args.dirs)
    df, more = learning_curve_table(files)
    for w in warns + more:
        print(w, file=sys.stderr)
    if df.empty:
        print(f"error: no trial logs with queries under {', '.join(args.dirs)}", file=sys.stderr)
        return 1
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(out / "learning_curve.csv", index=False)
    (out / "learning_curve.md").write_text(render_learning_curve(df, files))
    figure(df, out)
    print(f"wrote {out / 'learning_curve.md'}, learning_curve.csv and the figure ({len(df)} rows)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
