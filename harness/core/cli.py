"""Command-line plumbing shared by the Hydra entry points.

Hydra's argparse takes no overrides after `-m` (`python -m harness +env=rigid -m seed=0,1`
fails with "unrecognized arguments"), so the flag is moved to the front first. The
`+env=`/`+planner=` choices are checked before Hydra composes, so a missing or unknown
name gets one line listing the choices instead of Hydra's traceback-like report; so does
a `hydra.run.dir` / `hydra.sweep.dir` that cannot be created (Hydra makes it before our
code runs, and reports the OSError with a traceback), and so does a `problems=` file that does
not exist (before Hydra makes the run folder). A key override is checked against
the composed config (composed only when some key is not one of the command's own config
file's): Hydra accepts `+budget=5` and nothing reads it, and answers `budget=5` and `env=s2d`
with several lines of advice. `--help` is ours (harness/core/cli_help.py).
"""

from __future__ import annotations

import difflib
import functools
import random
import stat
import sys
import tempfile
import time
from pathlib import Path
from typing import NoReturn

CONF_DIR = Path(__file__).resolve().parents[2] / "conf"
MULTIRUN_FLAGS = ("-m", "--multirun")
ADDED_GROUPS = ("env", "planner", "experiment")  # no default: chosen with +group=NAME
# Keys the code reads when present (harness/core/config.py env_spec) that not every env declares.
OPTIONAL_KEYS = ("env.motion_step", "env.planner_range", "env.planning_margin", "env.expert.pairs", "env.expert.check")
# Maps that take any of their options with + whether a config has them or not (the networks'
# recipe options: harness.core.schema is their schema).
OPEN_MAPS = ("planner.networks.", "env.networks.", "env.paper_networks.")
# Hydra's flags that take the next argument as their value.
VALUE_FLAGS = ("-c", "--cfg", "-p", "--package", "-cn", "--config-name", "-cp", "--config-path", "-cd", "--config-dir")
HELP_FLAGS = ("-h", "--help")


class UsageError(Exception):
    """A mistake in the command (a choice, key or value; a file it names): one line on stderr
    and exit status 2 (docs/reliability.md, "Exit status"), whether run_hydra or the job finds it."""

    status = 2


class RunRefused(UsageError):
    """The command is right, but what the run found refuses it (a cache it cannot write, a log
    resume refuses, more than one thread per pool): one line, exit status 1."""

    status = 1


def normalize_argv(argv: list[str]) -> list[str]:
    """Move -m/--multirun to the front so overrides may stand on both sides of it."""
    rest = [a for a in argv if a not in MULTIRUN_FLAGS]
    return (["--multirun"] if len(rest) != len(argv) else []) + rest


SEARCHPATH = "hydra.searchpath"


def _searchpath_entries(argv) -> list[str]:
    """The entries of a `hydra.searchpath=[file://...,pkg://...]` override, if any."""
    for arg in argv:
        key, sep, value = arg.partition("=")
        if sep and key.lstrip("+~") == SEARCHPATH:
            return [v.strip().strip("'\"") for v in value.strip().strip("[]").split(",") if v.strip()]
    return []


def _entry_dir(entry: str) -> Path | None:
    """The folder of a search-path entry: file://DIR, or pkg://a.b (package a.b's folder)."""
    import importlib.util

    if entry.startswith("file://"):
        return Path(entry[len("file://") :])
    if entry.startswith("pkg://"):
        dotted = entry[len("pkg://") :].strip("/").replace("/", ".")
        head, _, rest = dotted.partition(".")
        try:
            spec = importlib.util.find_spec(head)
        except (ImportError, ValueError):
            return None
        if spec is None or not spec.submodule_search_locations:
            return None
        return Path(list(spec.submodule_search_locations)[0]).joinpath(*filter(None, rest.split(".")))
    return None


def search_dirs(argv=()) -> list[Path]:
    """Our conf/ and the folders a `hydra.searchpath` override adds (a planner or env of
    one's own: README "Benchmark your own planner"), in Hydra's order (ours first)."""
    return [CONF_DIR] + [d for d in map(_entry_dir, _searchpath_entries(argv)) if d is not None]


def choices(group: str, argv=()) -> list[str]:
    """The names of a config group, in our conf/ and on the command line's search path."""
    return sorted({p.stem for d in search_dirs(argv) for p in (d / group).glob("*.yaml")})


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
        names = choices(group, argv)
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
                close = difflib.get_close_matches(v, names, n=1)
                raise UsageError(
                    f"unknown {group} {v!r} ({f'did you mean {close[0]}? ' if close else ''}"
                    f"choices: {', '.join(names)}; one of your own: its folder's parent "
                    f'with hydra.searchpath=[file://DIR], README "Benchmark your own planner")'
                )


FILE_KEYS = ("problems",)  # keys that name an input file or folder


def missing_file(key: str, value) -> str | None:
    """The one-line complaint about a file or folder a key names that does not exist; None when
    it exists or none is named."""
    if value in (None, "", "null") or Path(str(value)).exists():
        return None
    return f"{key}={value}: no such file or folder"


def check_files(argv: list[str]) -> None:
    """UsageError for an input file named on the command line that does not exist (`problems=`),
    before Hydra makes the run folder; a value with an interpolation is left to settings_of."""
    for arg in _overrides(argv):
        key = arg.partition("=")[0].lstrip("+")
        if key in FILE_KEYS and "${" not in arg:
            for value in _override_values([arg.lstrip("+")], key) or []:
                value = value.strip("'\"")
                if "*" not in value and (message := missing_file(key, value)):
                    raise UsageError(message)


def _overrides(argv: list[str]) -> list[str]:
    out, skip = [], False
    for a in argv:
        if not skip and not a.startswith("-"):
            out.append(a)
        skip = a in VALUE_FLAGS
    return out


def _is_group(name: str, dirs=(CONF_DIR,)) -> bool:
    return "/" in name or any((d / name).is_dir() for d in dirs)


def check_plus(argv: list[str]) -> None:
    """UsageError for `env=s2d` (a group without a default needs +) and `+scale=tiny` (one with
    a default takes none)."""
    for arg in _overrides(argv):
        key, sep, value = arg.partition("=")
        if not sep:
            continue
        if key in ADDED_GROUPS:
            raise UsageError(f"write +{arg} ({key} is a choice added with +)")
        bare = key.lstrip("+")
        if key != bare and bare not in ADDED_GROUPS and _is_group(bare):
            raise UsageError(f"write {bare}={value} ({bare} has a default choice; + is for {', '.join(ADDED_GROUPS)})")


def _compose(config_name: str, overrides: list[str]):
    """The config Hydra would compose from these group choices, hydra.* included; None when
    it cannot (Hydra then reports why itself)."""
    from hydra import compose, initialize_config_dir
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    try:
        with initialize_config_dir(str(CONF_DIR), version_base="1.3"):
            return compose(config_name, overrides, return_hydra_config=True)
    except (HydraException, OmegaConfBaseException):
        return None


def _dotted(node, prefix: str = "") -> list[str]:
    from omegaconf import DictConfig

    out = []
    for k in node.keys():
        child = node._get_node(k)
        out.append(prefix + str(k))
        if isinstance(child, DictConfig) and not child._is_none():
            out += _dotted(child, f"{prefix}{k}.")
    return out


def _lookup(cfg, key: str) -> str:
    """'known', 'open' (under a map that takes any key, as planner.params) or 'unknown'."""
    from omegaconf import DictConfig, ListConfig

    node = cfg
    for part in key.split("."):
        if isinstance(node, ListConfig) or node._is_none():
            return "open"
        if not isinstance(node, DictConfig):
            return "unknown"
        if len(node) == 0:
            return "open"
        if part not in node:
            return "unknown"
        node = node._get_node(part)
    return "known"


def _swept_groups(cfg, given: list[str]) -> list[str]:
    """The group choices an experiment's sweep makes (`+env: s2d,c2d` in conf/experiment/),
    their first values, so that keys under them can be checked too."""
    params = cfg.hydra.sweeper.get("params") or {}
    names = {g.partition("=")[0].lstrip("+~") for g in given}
    out = []
    for key, value in params.items():
        bare = key.lstrip("+~")
        first = (_override_values([f"{bare}={value}"], bare) or [""])[0]
        if bare not in names and _is_group(bare) and first and "*" not in first:
            out.append(f"{key}={first}")
    return out


OUTPUT_DIR_KEYS = ("hydra.run.dir", "hydra.sweep.dir")
HYDRA_KEYS = (*OUTPUT_DIR_KEYS, "hydra.sweep.subdir", "hydra.job.chdir")  # in every Hydra config


@functools.cache
def _plain_keys(config_name: str) -> frozenset[str]:
    """The keys that every config composed from conf/CONFIG_NAME.yaml has, read from that file
    and the files its defaults list by name (not a group's choice), without composing: those
    of them that hold a value, not a map (a map may take new keys, which need a +)."""
    import yaml

    doc = yaml.safe_load((CONF_DIR / f"{config_name}.yaml").read_text()) or {}
    keys = {k for k, v in doc.items() if k not in ("defaults", "hydra") and not isinstance(v, dict)}
    for entry in doc.get("defaults") or []:
        if isinstance(entry, str) and entry != "_self_" and (CONF_DIR / f"{entry}.yaml").is_file():
            keys |= _plain_keys(entry)
    return frozenset(keys) | frozenset(HYDRA_KEYS)


def check_keys(argv: list[str], config_name: str) -> None:
    """UsageError for an override of a key that the composed config lacks (naming the closest
    one), and for `+key=` on a key it has. Keys of a group an experiment's sweep chooses
    (planner.* under +experiment=table1) are left to Hydra."""
    groups, keys = [], []
    dirs = search_dirs(argv)
    for arg in _overrides(argv):
        key, sep, value = arg.partition("=")
        bare = key.lstrip("+~")
        if "@" in bare or not bare:
            continue
        if bare == SEARCHPATH:  # composed with it, so that a planner of one's own is found
            groups.append(arg)
        elif _is_group(bare, dirs):
            values = _override_values([f"{bare}={value}"], bare) or []
            if values and "*" not in values[0]:
                groups.append(f"{key}={values[0]}")
        elif sep or key.startswith("~"):
            keys.append((key, bare, value))
    if all(key == bare and bare in _plain_keys(config_name) for key, bare, _ in keys):
        return  # keys every composition has: no need to compose (~0.16 s of each command)
    cfg = _compose(config_name, groups)
    swept = [] if cfg is None else _swept_groups(cfg, groups)
    if swept:
        cfg = _compose(config_name, groups + swept)
    if cfg is None:
        return
    for key, bare, value in keys:
        found = "known" if bare in OPTIONAL_KEYS else _lookup(cfg, bare)
        if found == "unknown" and bare.startswith(OPEN_MAPS):
            found = "open"
        if found == "known" and key.startswith("+") and not key.startswith("++") and bare not in OPTIONAL_KEYS:
            raise UsageError(f"write {bare}={value} ({bare} is already in the config; + adds a new key)")
        if found == "open" and not key.startswith(("+", "~")):
            raise UsageError(f"write +{bare}={value} ({bare} is a new key: add it with +)")
        if found != "unknown" or (bare.split(".")[0] not in cfg and _is_group(bare.split(".")[0], dirs)):
            continue
        known = [k for k in _dotted(cfg) if bare.startswith("hydra.") or not k.startswith("hydra")]
        close = difflib.get_close_matches(bare, known, n=1)
        raise UsageError(f"unknown config key {bare}" + (f" (did you mean {close[0]}?)" if close else ""))


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


def _check_writable_dir(key: str, path: Path, attempts: int = 20) -> None:
    """Create what is missing of `path`, write a file there, and remove what was made. Jobs
    of a sweep may check the same folder at once: one made by another is left to it, and
    one removed by another under our feet is made again (another attempt)."""
    for attempt in range(attempts):
        try:
            return _try_writable_dir(path)
        except FileNotFoundError as e:
            if attempt + 1 < attempts:
                # a random pause, growing: without one, jobs that make and remove the folder
                # in step can keep one of them failing every attempt (seen on a loaded machine)
                time.sleep(random.uniform(0, 0.001 * 2 ** min(attempt, 6)))
                continue
            error = e
        except OSError as e:
            error = e
        raise UsageError(f"config key {key}: cannot create or write {path} ({error.strerror or error})")


def _is_file(path: Path) -> bool:
    """Something other than a folder (one stat: a folder another job removes and makes
    again must not look like a file between two calls)."""
    try:
        return not stat.S_ISDIR(path.stat().st_mode)
    except FileNotFoundError:
        return False
    except NotADirectoryError:
        return True


def _try_writable_dir(path: Path) -> None:
    missing = [p for p in (path, *path.parents) if not p.exists() and not p.is_symlink()]
    made = []
    try:
        for p in reversed(missing):
            try:
                p.mkdir()
            except FileExistsError:
                if not _is_file(p):  # a folder, or one made and removed by another job meanwhile
                    continue
                raise
            made.append(p)
        tempfile.TemporaryFile(dir=path).close()
    finally:
        for p in reversed(made):
            try:
                p.rmdir()
            except OSError:  # another job of the sweep has written into it meanwhile
                pass


def refuse(message, status: int, run_dir: Path | str | None = None) -> NoReturn:
    """One line on stderr and exit `status`; the run folder Hydra made for the job (run_dir
    where no Hydra job runs in this process: a sweep's job in its own process) is removed
    when nothing but Hydra's start files is in it (harness.core.run_dir)."""
    from harness.core.run_dir import discard

    print(f"error: {message}", file=sys.stderr)
    discard(run_dir)
    sys.exit(status)


def status_of(error: Exception) -> int:
    """A one-line error's exit status: a UsageError's own (2, or 1 for RunRefused); 1 for the
    others (a malformed problem file, a run that failed)."""
    return error.status if isinstance(error, UsageError) else 1


def user_errors(main):
    """A Hydra task function whose user-facing errors (UsageError, a problem file's) are one
    line on stderr and their exit status (refuse); Hydra would report them as a traceback."""

    @functools.wraps(main)
    def wrapped(*args, **kwargs):
        from mpnet.problems import ProblemFileError

        try:
            return main(*args, **kwargs)
        except (UsageError, ProblemFileError) as e:
            refuse(e, status_of(e))

    return wrapped


def _prog() -> str:
    """`harness.data` for `python -m harness.data`, `harness` for `python -m harness`."""
    spec = getattr(sys.modules["__main__"], "__spec__", None)
    return spec.name.removesuffix(".__main__") if spec else ""


def run_hydra(main, required: tuple[str, ...], optional: tuple[str, ...] = ("scale",)) -> None:
    """Check and normalise sys.argv, then call a @hydra.main function."""
    from harness.core.cli_help import ENTRIES, help_text

    argv = sys.argv[1:]
    prog = _prog()
    if prog in ENTRIES and any(a in HELP_FLAGS for a in argv):
        print(help_text(prog))
        sys.exit(0)
    if not any(a in ("-h", "--help", "--hydra-help", "--info", "--cfg", "-c") or a.startswith("--info") for a in argv):
        try:
            check_plus(argv)
            check_groups(argv, required, optional)
            check_output_dirs(argv)
            check_files(argv)
            check_keys(argv, ENTRIES[prog].config if prog in ENTRIES else "config")
        except UsageError as e:
            refuse(e, e.status)
    sys.argv = [sys.argv[0]] + normalize_argv(argv)
    try:
        main()
    except KeyboardInterrupt as e:  # its message, if any, says what was kept
        print(f"interrupted: {e}" if str(e) else "interrupted", file=sys.stderr)
        sys.exit(130)
