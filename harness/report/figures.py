"""The figures, as PNG and SVG: mean time and success per planner (the paper's Fig. 4), per-query times,
and one example workspace per env with an MPNet and a BIT* path (its Fig. 3)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from harness.log import painter_for
from harness.report.facts import Facts
from harness.report.load import TrialFile
from harness.report.names import PLANNER_COLORS, env_label, env_rank, natural_key, split_rank
from harness.report.render import fmt_g


def _figure(n_panels: int, w: float = 4.0, h: float = 3.4):
    from matplotlib.figure import Figure

    ncols = min(max(n_panels, 1), 4)
    nrows = math.ceil(max(n_panels, 1) / ncols)
    fig = Figure(figsize=(w * ncols, h * nrows), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[n_panels:]:
        ax.set_visible(False)
    return fig, axes[:n_panels]


def _save(fig, out: Path, name: str) -> list[Path]:
    import matplotlib

    paths = []
    with matplotlib.rc_context({"svg.hashsalt": "mpnet-bench"}):
        for ext in ("png", "svg"):
            p = out / f"{name}.{ext}"
            fig.savefig(p, dpi=120 if ext == "png" else None, metadata={"Date": None} if ext == "svg" else None)
            paths.append(p)
    return paths


def _grouped_bars(
    res: pd.DataFrame, facts: Facts, value: str, err: str, scale: float, ylabel: str, log: bool, title: str
):
    """One panel per env: splits on x, one bar per planner (error bar: std), as the paper's Fig. 4."""
    envs = sorted(res["env"].unique(), key=env_rank)
    planners = sorted(res["planner"].unique(), key=facts.rank)
    fig, axes = _figure(len(envs))
    width = 0.8 / max(len(planners), 1)
    for ax, env in zip(axes, envs):
        d = res[res["env"] == env]
        splits = sorted(d["split"].unique(), key=split_rank)
        x = np.arange(len(splits))
        for k, p in enumerate(planners):
            dp = d[d["planner"] == p].set_index("split").reindex(splits)
            m = dp[value].to_numpy(float) * scale
            s = np.nan_to_num(dp[err].to_numpy(float) * scale)
            lower = np.minimum(s, 0.9 * m) if log else s  # a log axis has no zero: clip the lower bar
            ax.bar(
                x - 0.4 + width * (k + 0.5),
                m,
                width,
                yerr=np.vstack([lower, s]),
                capsize=2,
                color=PLANNER_COLORS.get(p),
                label=facts.label(p),
                error_kw={"elinewidth": 0.8},
            )
        ax.set_xticks(x, splits)
        ax.set_title(env_label(env))
        ax.set_ylabel(ylabel)
        if log:
            ax.set_yscale("log")
        ax.grid(axis="y", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=min(len(labels), 6), frameon=False)
    fig.suptitle(title)
    return fig


def fig_time_per_planner(res: pd.DataFrame, facts: Facts):
    d = res[np.isfinite(res["time_mean_s"].astype(float))] if len(res) else res
    if d.empty:
        return None
    return _grouped_bars(
        d,
        facts,
        "time_mean_s",
        "time_std_s",
        1.0,
        "planning time [s]",
        True,
        "Mean planning time ± std (successful queries)",
    )


def fig_success(res: pd.DataFrame, facts: Facts):
    if res.empty:
        return None
    return _grouped_bars(
        res, facts, "success_mean", "success_std", 100.0, "success [%]", False, "Success rate, mean ± std over seeds"
    )


def fig_time_boxplot(q: pd.DataFrame, facts: Facts):
    ok = q[q["success"] & (q["time_s"] > 0)]
    if ok.empty:
        return None
    envs = sorted(ok["env"].unique(), key=env_rank)
    fig, axes = _figure(len(envs))
    for ax, env in zip(axes, envs):
        d = ok[ok["env"] == env]
        planners = sorted(d["planner"].unique(), key=facts.rank)
        data = [d.loc[d["planner"] == p, "time_s"].to_numpy() for p in planners]
        bp = ax.boxplot(
            data,
            tick_labels=[facts.label(p) for p in planners],
            whis=(5, 95),
            showfliers=False,
            patch_artist=True,
            medianprops={"color": "black"},
        )
        for box, p in zip(bp["boxes"], planners):
            box.set_facecolor(PLANNER_COLORS.get(p, "#bbbbbb"))
        ax.set_yscale("log")
        ax.set_title(env_label(env))
        ax.set_ylabel("planning time [s]")
        ax.tick_params(axis="x", labelrotation=30)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle("Per-query planning time of successes (box: quartiles, whiskers: 5th-95th percentile)")
    return fig


def pick_example(q: pd.DataFrame, env: str) -> tuple[dict[str, int], int] | None:
    """Rows of q to draw for env ({planner: row}, and the row whose workspace is drawn): the
    first query, in (split, workspace, query, seed) order, that an MPNet planner (mpnet_nr,
    else mpnet_hr) and BIT* both solved in the same workspace; failing that, the first solved
    query of any planner, with every planner that solved it too."""
    d = q[(q["env"] == env) & q["success"]]
    if d.empty:
        return None
    keys = [
        (split_rank(s), natural_key(w), natural_key(i), seed)
        for s, w, i, seed in zip(
            d["split"].tolist(), d["workspace_id"].tolist(), d["query_id"].tolist(), d["seed"].tolist()
        )
    ]
    d = d.iloc[sorted(range(len(d)), key=keys.__getitem__)]
    d = d.drop_duplicates(["planner", "split", "workspace_id", "query_id"])  # each planner's first seed
    solved = {
        p: dict(zip(zip(g["split"], g["workspace_id"], g["query_id"]), g.index))
        for p, g in d.groupby("planner", sort=False)
    }
    bit = solved.get("bit_star", {})
    for mp in ("mpnet_nr", "mpnet_hr"):
        for key, r in solved.get(mp, {}).items():  # in the sorted order
            if key in bit:
                return {mp: r, "bit_star": bit[key]}, r
    r = d.index[0]
    key = (d.at[r, "split"], d.at[r, "workspace_id"], d.at[r, "query_id"])
    return {p: rows[key] for p, rows in solved.items() if key in rows}, r


def fig_example(q: pd.DataFrame, files: list[TrialFile], env: str, facts: Facts):
    """One workspace of env: obstacles, start, goal and the chosen planners' paths."""
    from matplotlib.patches import Rectangle

    pick = pick_example(q, env)
    if pick is None:
        return None
    chosen, ref = pick
    tf = files[int(q.at[ref, "file"])]
    msg = tf.queries[int(q.at[ref, "qidx"])]
    ws = tf.workspaces.get((str(msg.get("split")), str(msg.get("workspace_id"))))
    if ws is None:
        return None
    wd = len((ws.get("obstacles") or [{"center": [0, 0]}])[0]["center"])
    try:
        painter = painter_for(ws.get("robot"), wd)
    except ValueError:  # a robot kind without a painter: no example figure
        return None
    fig, (ax,) = _figure(1, 6.0, 6.0)
    bounds = ws.get("bounds") or [[-20, 20], [-20, 20]]
    for o in ws.get("obstacles", []):
        c, s = np.asarray(o["center"], float), np.asarray(o["size"], float)
        ax.add_patch(
            Rectangle(
                tuple(c[:2] - s[:2] / 2),
                s[0],
                s[1],
                facecolor="0.55",
                alpha=0.85 if wd == 2 else 0.35,
                edgecolor="0.3",
                lw=0.5,
            )
        )
    for p in sorted(chosen, key=facts.rank):
        r = chosen[p]
        m = files[int(q.at[r, "file"])].queries[int(q.at[r, "qidx"])]
        path = np.asarray(m.get("path") or [], float)
        if path.ndim != 2 or len(path) < 2:
            continue
        color = PLANNER_COLORS.get(p, "black")
        ax.plot(
            path[:, 0],
            path[:, 1],
            "-o",
            color=color,
            ms=3,
            lw=1.8,
            label=f"{facts.label(p)} (cost {fmt_g(q.at[r, 'path_cost'])}, {fmt_g(q.at[r, 'time_s'])} s)",
        )
        for o in painter.footprints(path):
            ax.plot(o[:, 0], o[:, 1], color=color, lw=0.7, alpha=0.6)
    start, goal = np.asarray(msg["start"], float), np.asarray(msg["goal"], float)
    ax.plot(*start[:2], "o", color="#2050f0", ms=9, label="start", zorder=5)
    ax.plot(*goal[:2], "*", color="#f09000", ms=14, label="goal", zorder=5)
    ax.set_xlim(*bounds[0])
    ax.set_ylim(*bounds[1])
    ax.set_aspect("equal")
    proj = ", x-y projection" if wd == 3 else ""
    ax.set_title(
        f"{env_label(env)}: {msg.get('split')} workspace {msg.get('workspace_id')}, query {msg.get('query_id')}{proj}",
        fontsize=10,
    )
    fig.legend(loc="outside lower center", ncols=2, fontsize=8, frameon=False)
    return fig


def write_figures(
    res: pd.DataFrame, q: pd.DataFrame, files: list[TrialFile], out: Path, facts: Facts
) -> tuple[list[Path], list[str]]:
    """Every figure the data allows, as PNG and SVG; a figure without data is left out, one
    whose data is malformed is left out with a warning line. The PNG and SVG files of an
    earlier report in out are removed first, so none outlives the data it was drawn from."""
    out.mkdir(parents=True, exist_ok=True)
    for old in out.iterdir():
        if old.suffix.lower() in (".png", ".svg") and (old.is_file() or old.is_symlink()):
            old.unlink()
    makers = [
        ("time_per_planner", lambda: fig_time_per_planner(res, facts)),
        ("success", lambda: fig_success(res, facts)),
        ("time_boxplot", lambda: fig_time_boxplot(q, facts)),
    ]
    makers += [
        (f"example_{env}", lambda env=env: fig_example(q, files, env, facts))
        for env in sorted(q["env"].unique(), key=env_rank)
    ]
    written, warns = [], []
    for name, make in makers:
        try:
            fig = make()
        except (KeyError, IndexError, TypeError, ValueError) as e:
            warns.append(f"warning: figure {name} left out: malformed data in the logs ({type(e).__name__}: {e})")
            continue
        if fig is not None:
            written += _save(fig, out, name)
    return written, warns
