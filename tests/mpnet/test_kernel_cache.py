"""numba's on-disk kernel cache keyed on every source a kernel reaches (mpnet.jit): an edit of a
kernel another kernel calls or inlines recompiles the caller, in a fresh process, and nothing
recompiles when nothing changed. Each test edits a temporary copy, never the checkout."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from mpnet import jit

CALLEE = """
from mpnet.jit import njit

@njit(cache=True, inline="always")
def leaf(x):
    return x + {value}
"""
CALLER = """
from mpnet.jit import njit
from mpnet.callee import leaf

@njit(cache=True)
def outer(x):
    return leaf(x) * 10
"""
APART = """
from mpnet.jit import njit

@njit(cache=True)
def alone(x):
    return x - 1
"""
PROBE = """
from mpnet.caller import outer
from mpnet.apart import alone
print(outer(1), alone(1), outer.stats.cache_hits.get(outer.signatures[0], 0),
      alone.stats.cache_hits.get(alone.signatures[0], 0))
"""


def _run(root: Path, code: str, cache: str | None = "kernels") -> str:
    """code run in a fresh interpreter on the copy at root, its kernels cached in root/cache
    (None: no NUMBA_CACHE_DIR, numba's user-wide place under root/home)."""
    env = {**os.environ, "PYTHONPATH": str(root), "HOME": str(root / "home"), "XDG_CACHE_HOME": str(root / "home")}
    env.pop("NUMBA_CACHE_DIR", None)
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(root / cache)
    code = f"import mpnet; assert mpnet.__file__.startswith({str(root)!r}), mpnet.__file__\n{code}"
    p = subprocess.run([sys.executable, "-c", code], cwd=root, env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    return p.stdout.split()


@pytest.fixture()
def package(tmp_path) -> Path:
    """A package named mpnet holding mpnet.jit and three kernel modules: caller inlines callee's
    kernel; apart reaches neither."""
    pkg = tmp_path / "mpnet"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    shutil.copy(jit.__file__, pkg / "jit.py")
    (pkg / "callee.py").write_text(CALLEE.format(value=1))
    (pkg / "caller.py").write_text(CALLER)
    (pkg / "apart.py").write_text(APART)
    return tmp_path


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_an_edit_of_an_inlined_kernel_recompiles_its_caller(package):
    assert _run(package, PROBE) == ["20", "0", "0", "0"]  # compiled: nothing cached yet
    assert _run(package, PROBE) == ["20", "0", "1", "1"]  # both loaded from the cache
    (package / "mpnet" / "callee.py").write_text(CALLEE.format(value=2))
    # numba's own stamp (caller.py's text) would load outer's old code here: 20, 1
    assert _run(package, PROBE) == ["30", "0", "0", "1"]  # outer recompiled; alone, which does not reach it, loaded


def _cached(folder: Path) -> set[str]:
    return {p.name.split(".")[0] for p in folder.rglob("*.nbi")}


@pytest.mark.slow  # compiles in fresh interpreters
def test_the_cache_is_never_beside_the_sources(package):
    """NUMBA_CACHE_DIR when set, numba's user-wide place when not: the checkout stays what git
    holds (issue 66), and the place read at a kernel's first use, not at its import."""
    _run(package, PROBE)
    assert _cached(package / "kernels") == {"caller", "apart"} and not _cached(package / "mpnet")
    _run(package, PROBE, cache=None)
    assert _cached(package / "home") == {"caller", "apart"} and not _cached(package / "mpnet")
    late = f"from mpnet.caller import outer\nimport numba\nnumba.config.CACHE_DIR = {str(package / 'late')!r}\n"
    _run(package, late + "print(outer(1))")
    assert _cached(package / "late") == {"caller"}


def test_the_stamp_follows_imports(package):
    """The reach is the module and what it imports from the package, transitively (each copy's
    own mpnet.jit, in a subprocess: jit.ROOT is the package it sits in)."""
    code = "from mpnet import jit; print(*(len(jit.reach(jit.ROOT / m)) for m in ('caller.py', 'apart.py')))"
    code += "; print(*(p.name for p in jit.reach(jit.ROOT / 'caller.py')))"
    assert _run(package, code) == ["3", "2", "callee.py", "caller.py", "jit.py"]


def test_an_edit_that_keeps_the_size_and_the_mtime_still_changes_the_stamp(package):
    """A file's memo in a process (mpnet.jit._version) is not fooled by a copy that keeps the
    old mtime (`cp -p`, rsync -a): a sweep's jobs share it with their parent (warm_stamps)."""
    code = textwrap.dedent(
        """
        import os
        from mpnet import jit
        callee, caller = jit.ROOT / "callee.py", jit.ROOT / "caller.py"
        jit.warm_stamps()
        before, st = jit.reach_digest(caller), callee.stat()
        callee.write_text(callee.read_text().replace("x + 1", "x + 2"))
        os.utime(callee, ns=(st.st_atime_ns, st.st_mtime_ns))
        now = callee.stat()
        print(now.st_size == st.st_size, now.st_mtime_ns == st.st_mtime_ns, before != jit.reach_digest(caller))
        """
    )
    assert _run(package, code) == ["True", "True", "True"]


def test_the_stamp_does_not_depend_on_where_the_package_is(package, tmp_path_factory):
    other = tmp_path_factory.mktemp("elsewhere")
    shutil.copytree(package / "mpnet", other / "mpnet")
    # jit.ROOT is the checkout's package: compare through each copy's own jit in a subprocess
    code = "from mpnet import jit; print(jit.reach_digest(jit.ROOT / 'caller.py'))"
    assert _run(package, code) == _run(other, code)


def test_the_repository_kernels_reach_what_they_inline():
    """The compiled MPNet loop's stamp covers the point, rigid, sphere and Pnet kernels it
    inlines, through the kind modules compiled_env imports by name; the sphere checks' covers
    sphere_kernels (once a hand-pinned digest)."""
    root = jit.ROOT
    reach = lambda m: {p.relative_to(root).as_posix() for p in jit.reach(root / m)}  # noqa: E731
    assert {
        "envs/checkers/compiled_env.py",
        "envs/checkers/boxes_compiled.py",  # the robot kinds compiled_env finds by name (DISCOVERS)
        "envs/checkers/spheres_compiled.py",
        "envs/checkers/point_kernels.py",
        "envs/checkers/rigid_kernels.py",
        "envs/checkers/sphere_checks.py",
        "envs/checkers/sphere_kernels.py",
        "models/pnet_kernel.py",
    } <= reach("planners/compiled/kernels.py")
    assert "envs/checkers/sphere_kernels.py" in reach("envs/checkers/sphere_checks.py")
    # the packed layout the views are generated from
    assert "envs/checkers/sphere_layout.py" in reach("envs/checkers/sphere_checks.py")
    # a Python-side module does not recompile it
    assert "envs/checkers/spheres.py" not in reach("envs/checkers/sphere_checks.py")
    # the geometry written once: the kinematics (checker and IK), the slab test (point checks)
    assert "envs/arm/kinematics.py" in reach("envs/checkers/sphere_checks.py") & reach("envs/arm/ik_kernels.py")
    assert "envs/geometry.py" in reach("planners/compiled/kernels.py")
    assert "envs/arm/model.py" not in reach("envs/arm/kinematics.py")  # nor the Python-side model


PLANNER_PROBE = textwrap.dedent(
    """
    import numpy as np
    from mpnet.envs.scenes.generators import make_workspace
    from mpnet.envs.specs import get_spec
    from mpnet.planners.compiled import kernels as K
    from mpnet.planners.compiled.planner import kernel_env

    spec = get_spec("s2d")
    checker = spec.make_checker(make_workspace(spec, 0, "seen"))
    rng = np.random.default_rng(0)
    inside = lambda q: any(((q >= lo) & (q <= hi)).all() for lo, hi in zip(checker.lo, checker.hi))  # noqa: E731
    q = next(q for q in (spec.space.sample(rng) for _ in range(1000)) if not inside(q))  # free, not asked of a kernel
    env, counts = kernel_env(checker), np.zeros(3, np.int64)
    print(checker.is_valid(list(q)), K.is_valid(env, counts, np.asarray(q, float)))
    """
)


@pytest.mark.slow
def test_an_edit_of_a_point_kernel_reaches_the_compiled_planner(repo, tmp_path):
    """The case found by hand: point_kernels.state_free made to refuse every state, in a copy;
    the checker (whose check it is) and the compiled planner's state check (which inlines it)
    then refuse too."""
    shutil.copytree(repo / "mpnet", tmp_path / "mpnet", ignore=shutil.ignore_patterns("*.nbi", "*.nbc"))
    assert _run(tmp_path, PLANNER_PROBE) == ["True", "True"]
    kernels = tmp_path / "mpnet" / "envs" / "checkers" / "point_kernels.py"
    text = kernels.read_text()
    edited = text.replace('"""In bounds and in no closed box."""', '"""Refuses."""\n    return False')
    assert edited != text
    kernels.write_text(edited)
    assert _run(tmp_path, PLANNER_PROBE) == ["False", "False"]
