"""The report's own tables, kept as data beside its code (published figures, the summary's rows):
the one place harness.report parses YAML. A run's facts come from its log, never from its config
(issue 27; tests/harness/log/test_facts.py)."""

from __future__ import annotations

from importlib import resources

import yaml


def own_table(name: str):
    """harness/report/<name>.yaml, parsed."""
    return yaml.safe_load((resources.files("harness") / "report" / f"{name}.yaml").read_text(encoding="utf-8"))
