"""The files the documented commands write and the files the text cites: the folders the
commands of README.md and docs/*.md write are ignored by git, and no page or comment cites a
file a clone lacks."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.doc_commands import REPO, _placeholder, documented_commands, parse

# Where the harness writes whatever a command names (Hydra's run and sweep folders, the cache),
# and the keys and options by which a command names another folder.
DEFAULT_OUTPUTS = ("outputs", "multirun", ".cache")
OUTPUT_KEYS = ("hydra.run.dir", "hydra.sweep.dir", "out", "export_dir", "cache_dir")


def written_folders() -> set[str]:
    """The repository's top folders that the documented commands write into: the defaults, the
    output keys' and `--out` values, harness.fetch_mbm's destination; `reports` (committed,
    written only when named) aside."""
    out = set(DEFAULT_OUTPUTS)
    for _, command in documented_commands():
        _, _, module, args = parse(command)
        paths = [a.split("=", 1)[1] for a in args if a.split("=", 1)[0].lstrip("+") in OUTPUT_KEYS and "=" in a]
        paths += [b for a, b in zip(args, args[1:]) if a == "--out"]
        if module == "harness.fetch_mbm":
            paths += [a for a in args if not a.startswith("-")][:1]
        out |= {Path(p).parts[0] for p in paths if p and not p.startswith("/") and not _placeholder(Path(p).parts[0])}
    return out - {"reports"}


def _git(*args: str) -> subprocess.CompletedProcess:
    if shutil.which("git") is None or not (REPO / ".git").exists():
        pytest.skip("not a git checkout")
    return subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True)


def test_folders_the_documented_commands_write_are_ignored_by_git():
    folders = written_folders()
    assert {"data", "runs"} <= folders  # harness.fetch_mbm data/mbm, hydra.run.dir=runs/prm
    ignored = {f for f in folders if _git("check-ignore", "--no-index", "-q", f"{f}/probe").returncode == 0}
    assert ignored == folders, f"not in .gitignore: {sorted(folders - ignored)}"
    for tracked in ("mpnet/data/probe", "tests/data/probe"):  # the root's data/ only
        assert _git("check-ignore", "--no-index", "-q", tracked).returncode == 1, tracked


# A citation of design notes kept outside the repository: it points at nothing in a clone.
ELSEWHERE = re.compile(r"\bDESIGN\b|\.\./shared|§")


def test_docs_and_code_cite_only_files_a_clone_has():
    """Code, docs, tests and configs (not reports/, generated; not docs/research/, whose § are
    its own sections) cite files of the repository, never notes kept beside it."""
    listed = _git("ls-files", "--cached", "--others", "--exclude-standard").stdout.splitlines()
    bad = []
    for name in listed:
        path = REPO / name
        if name.startswith(("reports/", "docs/research/")) or path == Path(__file__) or not path.is_file():
            continue
        try:
            text = path.read_text()
        except UnicodeDecodeError:  # weights, logs
            continue
        bad += [f"{name}:{i}: {line.strip()}" for i, line in enumerate(text.splitlines(), 1) if ELSEWHERE.search(line)]
    assert not bad, "\n".join(bad)
