"""numba's `njit`, whose on-disk cache is keyed on every source file a kernel can reach.

Why not numba's own `cache=True`: numba stamps a cached kernel with its own file's text only
(numba#1833). A kernel that calls, or inlines, a kernel of another module keeps the machine
code compiled from that module's old text after it changes: the compiled MPNet loop
(`mpnet/planners/compiled/kernels.py`) inlines the point, rigid, sphere and Pnet kernels, so
an edit of `point_kernels.state_free` did not reach the planner. Here the stamp is the digest
of the kernel's module and of every `mpnet` module it imports, transitively (module-level and
function-level imports alike, read from the source, so nothing is imported to find them; a
package's `__init__` only where a name is imported from it; a module's `DISCOVERS = "<glob>"`,
the modules beside it that it imports by name at run time, as compiled_env finds the robot
kinds): an
edit anywhere a kernel reaches recompiles that kernel, and only the kernels that reach it.

Where: `NUMBA_CACHE_DIR` (numba's setting) if set when a kernel is first compiled or
loaded, else numba's user-wide cache; never the source tree's `__pycache__` (a checkout stays
what git holds; the app puts kernels under its artifact cache: harness.core.kernels). The
place is settled at a kernel's first use, not at import, so a caller may set it after
importing the kernels' modules.
"""

from __future__ import annotations

import ast
import hashlib
import os
from functools import cache
from pathlib import Path

import numba
from numba.core.caching import (
    CompileResultCacheImpl,
    FunctionCache,
    UserProvidedCacheLocator,
    UserWideCacheLocator,
)

ROOT = Path(__file__).resolve().parent  # the package whose modules a stamp follows
PACKAGE = ROOT.name


def _module_file(name: str) -> Path | None:
    """The file of module `name` (dotted, inside this package), or None."""
    parts = name.split(".")
    if parts[0] != PACKAGE:
        return None
    base = ROOT.joinpath(*parts[1:])
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _version(st: os.stat_result) -> tuple[int, int, int, int]:
    """A file's version for the memos below: its inode, mtime, ctime and size (a copy that keeps
    an old mtime, `cp -p`, still changes the ctime, which no tool sets)."""
    return st.st_ino, st.st_mtime_ns, st.st_ctime_ns, st.st_size


@cache
def _imports(path: Path, version: tuple) -> tuple[Path, ...]:
    """The package's files that the module at `path` imports directly (text read once per
    version of the file: _version is the memo's key)."""
    tree = ast.parse(path.read_text(), str(path))
    names: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            # `from a.b import c`: c is a submodule of a.b, else a name a.b defines
            for a in node.names:
                sub = f"{node.module}.{a.name}"
                names.append(sub if _module_file(sub) is not None else node.module)
    found = {f for f in map(_module_file, names) if f is not None}
    for node in tree.body:  # DISCOVERS = "<glob>": modules beside it that it imports by name at run time
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "DISCOVERS" for t in node.targets):
            found |= {f.resolve() for f in path.parent.glob(node.value.value)}
    return tuple(sorted(found))


def reach(path: str | os.PathLike) -> list[Path]:
    """The module at `path` and every module of the package it imports, transitively, sorted."""
    seen: set[Path] = set()
    todo = [Path(path).resolve()]
    while todo:
        p = todo.pop()
        if p in seen:
            continue
        seen.add(p)
        st = p.stat()
        todo += [q for q in _imports(p, _version(st)) if q not in seen]
    return sorted(seen)


@cache
def _file_digest(path: Path, version: tuple) -> bytes:
    """sha256 of one file, read once per version of it (a module's kernels share its reach)."""
    return hashlib.sha256(path.read_bytes()).digest()


def reach_digest(path: str | os.PathLike) -> str:
    """sha256 over the text of every file in reach(path), each under its path in the package
    (so the stamp does not depend on where the package is installed)."""
    h = hashlib.sha256()
    for p in reach(path):
        rel = p.relative_to(ROOT).as_posix() if p.is_relative_to(ROOT) else p.name
        st = p.stat()
        h.update(f"{rel}\0".encode() + _file_digest(p, _version(st)))
    return h.hexdigest()


def warm_stamps() -> None:
    """Every module of the package parsed for its imports and hashed, as the stamps of its
    kernels will need: a process about to fork several children (a sweep's jobs) does it once,
    and each child inherits it (each had parsed and hashed the sources its kernels reach, ~0.3 s;
    a file's memo is keyed on its version, so an edit after is still seen)."""
    for p in sorted(ROOT.rglob("*.py")):
        version = _version(p.stat())
        _imports(p, version)
        _file_digest(p, version)


class _ReachStamp:
    """A numba cache locator whose freshness stamp is reach_digest, not the file's own text."""

    def get_source_stamp(self):
        return reach_digest(self._py_file)


class _UserProvided(_ReachStamp, UserProvidedCacheLocator):
    pass


class _UserWide(_ReachStamp, UserWideCacheLocator):
    pass


class _ReachCacheImpl(CompileResultCacheImpl):
    _locator_classes = [_UserProvided, _UserWide]  # numba's order, less the source tree


class ReachCache(FunctionCache):
    """numba's per-function cache (same files, same index) with the reach stamp."""

    _impl_class = _ReachCacheImpl


class _BorrowedCacheImpl(_ReachCacheImpl):
    def get_filename_base(self, fullname, abiflags):
        return super().get_filename_base(f"{fullname}_borrowed", abiflags)


class BorrowedReachCache(ReachCache):
    """ReachCache under other file names: a function compiled both ways keeps two caches."""

    _impl_class = _BorrowedCacheImpl


class _FirstUse:
    """A dispatcher's cache, made at its first use (numba makes it at decoration): the place
    is read then (see the module)."""

    def __init__(self, make):
        self._make, self._cache = make, None

    def __getattr__(self, name):
        if self._cache is None:
            self._cache = self._make()
        return getattr(self._cache, name)


def njit(*args, cache: bool = False, borrowed: bool = False, **options):
    """numba.njit; with cache=True, cached on disk under the reach stamp (see the module).

    borrowed=True compiles without numba's reference counts (its `_nrt=False`): every array
    passed, indexed out of a tuple or viewed costs an atomic increment and decrement, which
    was most of the arm's certified motion check (reports/rrt_connect_compiled/borrowed: the
    compiled RRT-Connect's median on MotionBenchMaker's 700 fell from 4.07 to 1.57 ms).
    A borrowed kernel allocates nothing, reads and writes only arrays its caller keeps alive,
    and hands the views it returns only to other borrowed kernels: a kernel that counts would
    release a reference it never got, and Python would get the viewed array's parent."""

    # Pinned either way: numba lets a callee without the flag inherit its first caller's, so a
    # counting kernel first compiled under a borrowed one would run (and be cached) borrowed.
    options["_nrt"] = not borrowed

    def wrap(func):
        dispatcher = numba.njit(**options)(func)
        if cache:
            # Dispatcher.enable_caching does exactly this with numba's FunctionCache
            kind = BorrowedReachCache if borrowed else ReachCache
            dispatcher._cache = _FirstUse(lambda: kind(dispatcher.py_func))
        return dispatcher

    if args and callable(args[0]):
        return wrap(args[0])
    return wrap
