"""The experiment app: Hydra entry points, bench runs, trial logs, reports."""
