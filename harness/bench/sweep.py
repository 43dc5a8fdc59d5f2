"""One table at the end of a sweep: every job's run, read back from its trials.mcap (the
record, so the table holds what the logs hold, whichever launcher ran the jobs)."""

from __future__ import annotations

from pathlib import Path

from hydra.experimental.callback import Callback
from omegaconf import DictConfig

from harness.bench.summary import summarize
from harness.log import MCAP_NAME, Tally, read_log


def sweep_rows(sweep_dir: Path) -> list[dict]:
    """Per run and split: env, planner, seed, queries, success, median time; with the
    run's queries logged / expected and its folder in the sweep (what tells apart runs of
    one env, planner and seed: a learning curve's sizes)."""
    rows = []
    for path in sorted(Path(sweep_dir).rglob(MCAP_NAME)):
        msgs, _ = read_log(path, ("/run", "/query"))
        run = next((m.data for m in msgs if m.topic == "/run"), None)
        if run is None:
            continue
        tally = Tally()
        for m in msgs:
            if m.topic == "/query":
                tally.add(m.data)
        expected = run.get("queries_expected")
        for r in summarize(tally):
            rows.append(
                {
                    "env": run.get("env"),
                    "planner": run.get("planner"),
                    "seed": run.get("seed"),
                    **r,
                    "logged": f"{len(tally)}/{expected}" if isinstance(expected, int) else str(len(tally)),
                    "run": path.parent.relative_to(sweep_dir).as_posix(),
                }
            )
    return rows


def format_sweep(rows: list[dict], sweep_dir: Path) -> str:
    head = (
        f"{'env':<6} {'planner':<22} {'seed':>5} {'split':<7} {'queries':>7} {'success':>8} "
        f"{'median (ms)':>11} {'logged':>9}  run"
    )
    lines = [f"sweep summary: {len({r['run'] for r in rows})} runs in {sweep_dir}", head]
    for r in rows:
        lines.append(
            f"{r['env']:<6} {r['planner']:<22} {r['seed']!s:>5} {r['split']:<7} {r['queries']:>7} "
            f"{r['success'] * 100:>7.1f}% {r['time_median_s'] * 1e3:>11.2f} {r['logged']:>9}  {r['run']}"
        )
    return "\n".join(lines)


class SweepSummary(Callback):
    """Hydra callback (conf/config.yaml): the sweep's table once every job has ended."""

    def on_multirun_end(self, config: DictConfig, **kwargs) -> None:
        sweep_dir = Path(config.hydra.sweep.dir)
        rows = sweep_rows(sweep_dir)
        if rows:
            print(format_sweep(rows, sweep_dir), flush=True)
