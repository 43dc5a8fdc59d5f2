"""Speed measurements: `python -m harness.perf` (perf.md), `harness.perf.torch_speed` (one torch device)."""
