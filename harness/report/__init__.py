"""`python -m harness.report DIR... [--label NAME=DIR]... [--out OUT] [--force] [--paper]`: the paper's
tables, figures and an OMPL benchmark database, regenerated from trial logs alone (docs/reports.md,
"The report"), into DIR/report/ unless --out names another folder; never into a folder the report did
not make (build.MARKER) without --force. Labelled runs are shown as `planner [NAME]`, never pooled.

Only the `trials.mcap` files found under the given directories are read (topics `/run`,
`/workspace`, `/query`): no planning, no artifacts, no torch or OMPL. A file that cannot be
read (empty, corrupt, no `/run`) is skipped with one warning line; a file cut short (a
killed writer, or truncated by hand) is read up to where it breaks, with one warning line;
a file with a `/run` but no `/query` gets one warning line. No query at all is an error.

How the numbers are computed (also written to OUT/README.md):
- Rows are env x split x planner, where split is each query's own `split` (a run's `/run`
  may say "seen+unseen" or "file").
- `queries` counts every logged query of every seed; `seeds` is the number of distinct
  seeds. Several files with the same (env, planner, seed), e.g. a sweep run twice, all
  count: their queries are pooled into that seed, with one warning line per (env, planner,
  seed) whose queries appear in more than one file. A file whose `/run` has no integer
  seed counts as a seed of its own (with a warning), so such files are never pooled.
- `success_mean` / `success_std`: mean and standard deviation of the per-seed success rates,
  the std with ddof=1 (sample std) when there are two seeds or more, 0 for a single seed.
- Time statistics (`time_*`) are over the successful queries of all seeds pooled that logged
  a finite time (the paper's convention: time to a first solution); `time_std_s` uses ddof=1
  when there are two such queries or more, else 0. `cpu_mean_s`, `cost_mean` and
  `collision_checks_median` are over all successful queries (each over those that logged it).
- `cpu_share`: the CPU time of every planned query over its wall time, pooled: below 0.9 the
  queries waited for the CPU (a loaded machine) and the report warns; above 1.1 a second thread
  ran (a run from before `harness.core.threads` made every timed process single-threaded).
- `timeouts`: queries that ran out of budget; `timeout_cpu_share`: their CPU time over their
  wall time, pooled. Below 0.9 the machine was loaded (the planner got less computing than
  its budget), the report warns, and that row's success rate is a lower bound.
- `pnet_calls_median`, `replans_mean` and `fallback_rate` are over every query that logged
  the field (NaN for planners that do not).
- Table I: mean ± std time in seconds, and the BIT*/MPNet (NR) ratio of mean times; other
  planners come after the ratio, so the first columns are the paper's layout. Table I,
  success_cost and the figures leave out the MPNet ablations (runs whose config changes one
  piece of MPNet, e.g. `mpnet_nr_random`: ablations.*); results.csv leaves out the
  time-to-equal-quality runs (a config with `planner.cost_target`, e.g. `bit_star_to_nr`:
  equal_quality.*), whose success means "reached MPNet-NR's cost". What a run is comes from
  its logged config, never from its planner's name (facts.py); rows keep the logged name.
- Intervals (95%): Wilson score for every success rate (pooled successes / queries);
  percentile bootstrap (BOOT_N resamples, seeded per row) for every median time and ratio of
  medians. Significance against the comparator (facts.py) at 5%: Fisher's exact test
  for success, the ratio-of-medians interval excluding 1 for time; "≈" marks a difference
  that is not significant.
- Path quality: path cost / the query's logged `reference_cost` (median, p90) over
  successful queries, and the median ratio to bit_star's path cost on the queries both
  solved (paired on env, split, seed, query id): quality.*.

The modules: load (the logs into frames), facts (what each planner is), stats, tables,
equal_quality, render (Markdown, LaTeX), figures, arena (benchmark.db), readme (OUT/README.md),
build (write_report) and __main__ (the command line).
"""

from __future__ import annotations

from harness.report.build import write_report

__all__ = ["write_report"]
