"""Command-line plumbing shared by the Hydra entry points.

Hydra's argparse takes no overrides after `-m` (`python -m harness +env=rigid -m seed=0,1`
fails with "unrecognized arguments"), so the flag is moved to the front first. The
`+env=`/`+planner=` choices are checked before Hydra composes, so a missing or unknown
name gets one line listing the choices instead of Hydra's traceback-like report; so does
a `hydra.run.dir` / `hydra.sweep.dir` that cannot be created (Hydra makes it before our
code runs, and reports the OSError with a traceback).
"""

from __future__ import annotations

import functools
import sys
import tempfile
from pathlib import Path

CONF_DIR = Path(__file__).resolve().parent.parent / "conf"
MULTIRUN_FLAGS = ("-m", "--multirun")


class UsageError(Exception):
    """A one-line message for the user; the entry point prints it and exits 2."""


def normalize_argv(argv: list[str]) -> list[str]:
    """Move -m/--multirun to the front so overrides may stand on both sides of it."""
    rest = [a for a in argv if a not in MULTIRUN_FLAGS]
    return (["--multirun"] if len(rest) != len(argv) else []) + rest


def choices(group: str) -> list[str]:
    return sorted(p.stem for p in (CONF_DIR / group).glob("*.yaml"))


def _override_values(argv: list[str], group: str) -> list[str] | None:
    """Values given for a config group (`+group=a,b`, `group=a`), or None when absent."""
    for arg in argv:
        key, sep, value = arg.partition("=")
        if sep and key.lstrip("+~") == group:
            value = value.strip()
            for prefix in ("choice(", "glob("):
                if value.startswith(prefix) and value.endswith(")"):
                    value = value[len(prefix) : -1]
            return [v.strip() for v in value.split(",")]
    return None


def check_groups(argv: list[str], required: tuple[str, ...], optional: tuple[str, ...] = ()) -> None:
    """Raise UsageError for a missing required group or an unknown name in any group."""
    has_experiment = _override_values(argv, "experiment") is not None
    for group in required + optional:
        names = choices(group)
        values = _override_values(argv, group)
        if values is None:
            if group in required and not has_experiment:
                raise UsageError(
                    f"choose {'an' if group[0] in 'aeiou' else 'a'} {group} with +{group}=NAME "
                    f"(choices: {', '.join(names)})"
                )
            continue
        for v in values:
            if v not in names and "*" not in v:
                raise UsageError(f"unknown {group} {v!r} (choices: {', '.join(names)})")


OUTPUT_DIR_KEYS = ("hydra.run.dir", "hydra.sweep.dir")


def check_output_dirs(argv: list[str]) -> None:
    """UsageError for an output-dir override that cannot be created and written (its part
    before any `${...}` interpolation; whatever this makes, it removes again)."""
    for arg in argv:
        key, sep, value = arg.partition("=")
        if not sep or key.lstrip("+~") not in OUTPUT_DIR_KEYS:
            continue
        static = value.split("${", 1)[0].strip()
        if static:
            _check_writable_dir(key.lstrip("+~"), Path(static))


def _check_writable_dir(key: str, path: Path) -> None:
    missing = [p for p in (path, *path.parents) if not p.exists() and not p.is_symlink()]
    made = []
    try:
        for p in reversed(missing):
            p.mkdir()
            made.append(p)
        tempfile.TemporaryFile(dir=path).close()
    except OSError as e:
        raise UsageError(f"config key {key}: cannot create or write {path} ({e.strerror or e})") from None
    finally:
        for p in reversed(made):
            p.rmdir()


def user_errors(main):
    """A Hydra task function whose user-facing errors (UsageError, a problem file's) are one
    line on stderr and exit status 1; Hydra would report them as a traceback."""

    @functools.wraps(main)
    def wrapped(*args, **kwargs):
        from mpnet.problems import ProblemFileError

        try:
            return main(*args, **kwargs)
        except (UsageError, ProblemFileError) as e:
            print(f"error: {e}", file=sys.stderr)
            sys.exit(1)

    return wrapped


def run_hydra(main, required: tuple[str, ...], optional: tuple[str, ...] = ("scale",)) -> None:
    """Check and normalise sys.argv, then call a @hydra.main function."""
    argv = sys.argv[1:]
    if not any(a in ("-h", "--help", "--hydra-help", "--info", "--cfg", "-c") or a.startswith("--info") for a in argv):
        try:
            check_groups(argv, required, optional)
            check_output_dirs(argv)
        except UsageError as e:
            print(f"error: {e}", file=sys.stderr)
            sys.exit(2)
    sys.argv = [sys.argv[0]] + normalize_argv(argv)
    try:
        main()
    except KeyboardInterrupt as e:  # its message, if any, says what was kept
        print(f"interrupted: {e}" if str(e) else "interrupted", file=sys.stderr)
        sys.exit(130)
