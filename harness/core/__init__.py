"""What every command shares: argv and its one-line errors (cli), `--help` (cli_help), the
run folder of a refused command (run_dir), thread pools (threads), provenance, the config's
checks (config) and its parsed, typed settings (settings).

Deliberately empty, and it must stay so: a timed command's first line imports
harness.core.threads before numpy, scipy, torch or numba load."""
