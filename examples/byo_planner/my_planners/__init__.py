"""A researcher's own planner, benchmarked by mpnet-bench from outside its repository (README
"Benchmark your own planner"): nothing here is imported by the bench until a config names it."""
