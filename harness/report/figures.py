"""The figures, as PNG and SVG: success per planner with its Wilson interval, the share solved within a
time budget, per-query times as boxes on a log axis (in place of the paper's mean bars of Fig. 4), and
one example workspace per env with an MPNet and a BIT* path (its Fig. 3); every one says its n."""

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
from harness.report.stats import wilson_arrays

# The report's figures, and those of earlier versions of it (removed when it runs again).
REPORT_FIGURES = ("success", "success_vs_time", "time_boxplot", "time_per_planner")
TAB10 = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf")


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


def _colors(planners: list[str]) -> dict[str, str]:
    """Each planner's color: the paper's planners their own, any other (a labelled run, an
    extra planner) the next free one of matplotlib's tab10, so series never share a color."""
    palette = [c for c in TAB10 if c not in PLANNER_COLORS.values()] + list(PLANNER_COLORS.values())
    others = [p for p in planners if p not in PLANNER_COLORS]
    return {p: PLANNER_COLORS.get(p) or palette[others.index(p) % len(palette)] for p in planners}


def fig_success(res: pd.DataFrame, facts: Facts):
    """One panel per env: each split x planner's pooled success rate with its Wilson 95% interval
    and its n in the row's label; the axis spans the intervals (not 0-100), so that 90% and 95%
    read apart."""
    if res.empty:
        return None
    envs = sorted(res["env"].unique(), key=env_rank)
    colors = _colors(sorted(res["planner"].unique(), key=facts.rank))
    rows = max(len(facts.sort(res[res["env"] == e])) for e in envs)
    fig, axes = _figure(len(envs), 5.0, 0.9 + 0.32 * rows)
    for ax, env in zip(axes, envs):
        d = facts.sort(res[res["env"] == env])
        y = np.arange(len(d))[::-1]
        rate, lo, hi = (100.0 * d[c].to_numpy(float) for c in ("success_rate", "success_ci_low", "success_ci_high"))
        for yi, r, a, b, p in zip(y, rate, lo, hi, d["planner"]):
            ax.errorbar(r, yi, xerr=[[r - a], [b - r]], fmt="o", color=colors[p], capsize=3)
        ax.set_yticks(y, [f"{s} {facts.label(p)} (n={n})" for s, p, n in zip(d["split"], d["planner"], d["queries"])])
        span = max(float(np.nanmax(hi) - np.nanmin(lo)), 1.0)
        ax.set_xlim(max(0.0, np.nanmin(lo) - 0.1 * span), min(100.0, np.nanmax(hi) + 0.1 * span))
        ax.set_xlabel("queries solved [%] (Wilson 95% interval)")
        ax.set_title(env_label(env))
        ax.grid(axis="x", alpha=0.3)
    fig.suptitle("Success rate, all seeds pooled (n: queries)")
    return fig


def fig_time_boxplot(q: pd.DataFrame, facts: Facts):
    """One panel per env: the planning times of the successes of each split x planner as boxes on a
    log axis (box: quartiles, whiskers: 5th-95th percentile), n solved of all in the labels."""
    ok = q[q["success"] & (q["time_s"] > 0)]
    if ok.empty:
        return None
    envs = sorted(ok["env"].unique(), key=env_rank)
    colors = _colors(sorted(ok["planner"].unique(), key=facts.rank))
    n_all = q.groupby(["env", "split", "planner"]).size()
    fig, axes = _figure(len(envs), 5.0, 4.2)
    for ax, env in zip(axes, envs):
        d = ok[ok["env"] == env]
        groups = facts.sort(d[["env", "split", "planner"]].drop_duplicates())
        keys = list(zip(groups["split"], groups["planner"]))
        data = [d.loc[(d["split"] == s) & (d["planner"] == p), "time_s"].to_numpy() for s, p in keys]
        bp = ax.boxplot(
            data,
            tick_labels=[
                f"{facts.label(p)}\n{s}, {len(x)}/{n_all[(env, s, p)]} solved" for (s, p), x in zip(keys, data)
            ],
            whis=(5, 95),
            showfliers=False,
            patch_artist=True,
            medianprops={"color": "black"},
        )
        for box, (_, p) in zip(bp["boxes"], keys):
            box.set_facecolor(colors[p])
        ax.set_yscale("log")
        ax.set_title(env_label(env))
        ax.set_ylabel("planning time of a success [s]")
        ax.set_xlabel("planner, split (n: solved / queries)")
        ax.tick_params(axis="x", labelrotation=60, labelsize=7)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle("Per-query planning time of successes (box: quartiles, whiskers: 5th-95th percentile)")
    return fig


def solved_within(times, n: int, budgets) -> pd.DataFrame:
    """The share of n queries solved within each time budget: times are the successes' times (a
    success without a finite time is never counted as within a budget), n all the queries
    (failures included). Columns budget_s, solved, n, share, ci_low, ci_high (Wilson 95%)."""
    t = np.sort(np.asarray(times, float))
    t = t[np.isfinite(t)]
    b = np.asarray(budgets, float)
    k = np.searchsorted(t, b, side="right")
    lo, hi = wilson_arrays(k, np.full(len(b), n))
    return pd.DataFrame(
        {"budget_s": b, "solved": k, "n": n, "share": k / n if n else np.nan, "ci_low": lo, "ci_high": hi}
    )


def success_vs_time(q: pd.DataFrame) -> pd.DataFrame:
    """solved_within per env x split x planner, at each of its successes' times (where its curve
    steps) and at the longest time any query of that env x split logged (the budget, in effect)."""
    parts = []
    for (env, split, planner), d in q.groupby(["env", "split", "planner"], sort=False):
        times = d.loc[d["success"], "time_s"].to_numpy(float)
        longest = np.nanmax(q.loc[(q["env"] == env) & (q["split"] == split), "time_s"].to_numpy(float), initial=0.0)
        grid = np.unique(np.append(times[np.isfinite(times)], longest))
        parts.append(solved_within(times, len(d), grid).assign(env=env, split=split, planner=planner))
    cols = ["env", "split", "planner", "budget_s", "solved", "n", "share", "ci_low", "ci_high"]
    return pd.concat(parts, ignore_index=True)[cols] if parts else pd.DataFrame(columns=cols)


def fig_success_vs_time(q: pd.DataFrame, facts: Facts):
    """One panel per env x split: each planner's share of queries solved within a time budget
    (log axis), a step at each success, with its Wilson 95% band; n in the legend."""
    curves = success_vs_time(q)
    curves = curves[curves["budget_s"] > 0]
    if curves.empty or not (curves["solved"] > 0).any():
        return None
    panels = facts.sort(curves[["env", "split"]].drop_duplicates(), ("env", "split"))
    colors = _colors(sorted(curves["planner"].unique(), key=facts.rank))
    fig, axes = _figure(len(panels))
    for ax, (env, split) in zip(axes, zip(panels["env"], panels["split"])):
        d = curves[(curves["env"] == env) & (curves["split"] == split)]
        x0 = d.loc[d["solved"] > 0, "budget_s"].min() / 2 if (d["solved"] > 0).any() else d["budget_s"].min() / 2
        for p in sorted(d["planner"].unique(), key=facts.rank):
            c = d[d["planner"] == p]
            n = int(c["n"].iat[0])
            lo0, hi0 = wilson_arrays([0], [n])
            x = np.append(x0, c["budget_s"].to_numpy(float))
            y, lo, hi = (
                np.append(v0, c[col].to_numpy(float))
                for v0, col in ((0.0, "share"), (lo0[0], "ci_low"), (hi0[0], "ci_high"))
            )
            ax.step(x, 100 * y, where="post", color=colors[p], label=f"{facts.label(p)} (n={n})")
            ax.fill_between(x, 100 * lo, 100 * hi, step="post", color=colors[p], alpha=0.2, lw=0)
        ax.set_xscale("log")
        ax.set_xlim(x0, d["budget_s"].max())
        ax.set_xlabel("time budget [s]")
        ax.set_ylabel("queries solved within it [%]")
        ax.set_title(f"{env_label(env)}, {split}", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right", frameon=True, framealpha=0.9)
    fig.suptitle("Share of queries solved within a time budget (band: Wilson 95%)")
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
    """One workspace of env: obstacles, start, goal and the chosen planners' paths, drawn by the
    painter of the logged robot kind (a point in 3D on 3D axes, a rigid body whole at every
    vertex); None when no painter draws that robot."""
    from matplotlib.figure import Figure

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
    fig = Figure(figsize=(6.0, 6.0), layout="constrained")
    ax = fig.add_subplot(projection=painter.mpl_projection)
    drawn = painter.mpl_workspace(ax, ws)
    colors = _colors(sorted(chosen, key=facts.rank))
    for p in sorted(chosen, key=facts.rank):
        r = chosen[p]
        m = files[int(q.at[r, "file"])].queries[int(q.at[r, "qidx"])]
        path = np.asarray(m.get("path") or [], float)
        if path.ndim != 2 or len(path) < 2:
            continue
        label = f"{facts.label(p)} (cost {fmt_g(q.at[r, 'path_cost'])}, {fmt_g(q.at[r, 'time_s'])} s)"
        drawn += painter.mpl_query(ax, m, colors[p], label)
    drawn += painter.mpl_endpoints(ax, msg)
    painter.mpl_frame(ax, ws, drawn)
    ax.set_title(
        f"{env_label(env)}\none query (n=1): {msg.get('split')} workspace {msg.get('workspace_id')}, "
        f"query {msg.get('query_id')}",
        fontsize=10,
    )
    fig.legend(loc="outside lower center", ncols=2, fontsize=8, frameon=False)
    return fig


def write_figures(
    res: pd.DataFrame, q: pd.DataFrame, files: list[TrialFile], out: Path, facts: Facts
) -> tuple[list[Path], list[str]]:
    """Every figure the data allows, as PNG and SVG; a figure without data is left out, one
    whose data is malformed is left out with a warning line. The PNG and SVG files of an
    earlier report in out are removed first, so none outlives the data it was drawn from; other
    tools' figures there (the screenshots in reports/table1/figures/) are kept."""
    out.mkdir(parents=True, exist_ok=True)
    for old in out.iterdir():
        ours = old.stem in REPORT_FIGURES or old.stem.startswith("example_")
        if ours and old.suffix.lower() in (".png", ".svg") and (old.is_file() or old.is_symlink()):
            old.unlink()
    makers = [
        ("success", lambda: fig_success(res, facts)),
        ("success_vs_time", lambda: fig_success_vs_time(q, facts)),
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
