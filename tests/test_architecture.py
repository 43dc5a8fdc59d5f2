"""The house rules, checked: data flows one way (import-linter's contracts in
pyproject.toml), no import cycle (function-level imports included), no module past
500 lines, and no test of the robot kind outside the space and robot classes."""

from __future__ import annotations

import ast
import re
import subprocess
import sys

import grimp
import pytest

MAX_LINES = 500
# Where a robot kind may be asked: its own classes (spaces, robots) and the registry that
# binds them; the log painters, which are chosen by the logged robot kind.
KIND_HOMES = {"mpnet/envs/spaces.py", "mpnet/envs/robots.py", "mpnet/envs/specs.py", "harness/log/painters.py"}


def _sources(repo):
    return sorted(p for pkg in ("mpnet", "harness") for p in (repo / pkg).rglob("*.py"))


def test_import_contracts_hold(repo, monkeypatch):
    from importlinter.cli import EXIT_STATUS_SUCCESS, lint_imports

    monkeypatch.chdir(repo)  # the contracts live in pyproject.toml
    assert lint_imports(no_cache=True) == EXIT_STATUS_SUCCESS


def _cycles(graph) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]
    for root in sorted(graph.modules):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.find_modules_directly_imported_by(root))))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph.find_modules_directly_imported_by(w)))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def test_no_import_cycle():
    graph = grimp.build_graph("mpnet", "harness")
    assert _cycles(graph) == []


def test_no_module_past_the_size_limit(repo):
    long = {str(p.relative_to(repo)): n for p in _sources(repo) if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert long == {}


def test_no_test_module_past_the_size_limit(repo):
    """The tests keep the code's rule (issue 66): a module past ~500 lines does two jobs."""
    tests = sorted((repo / "tests").rglob("*.py"))
    long = {str(p.relative_to(repo)): n for p in tests if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert tests and long == {}


def test_the_robot_kind_is_asked_only_of_its_classes(repo):
    pattern = re.compile(r"""is_se2|spec\.name\s*==|robot\.kind|robot\.get\(["']kind|robot\[["']kind|\brobot\s*==""")
    hits = [
        f"{p.relative_to(repo)}:{i}"
        for p in _sources(repo)
        if str(p.relative_to(repo)) not in KIND_HOMES
        for i, line in enumerate(p.read_text().splitlines(), 1)
        if pattern.search(line)
    ]
    assert hits == []


ROBOTS = {"panda", "franka", "ur5", "fetch", "baxter"}  # and every robot file's model name (below)
COMMANDS = ("fetch_mbm",)  # names that hold a robot's name as a word and name none


def _code_words(path) -> list[tuple[int, str]]:
    """(line, text) of every identifier and string constant but docstrings."""
    tree = ast.parse(path.read_text())
    docs = {
        id(n.body[0].value)
        for n in ast.walk(tree)
        if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
        and n.body
        and isinstance(n.body[0], ast.Expr)
        and isinstance(n.body[0].value, ast.Constant)
    }
    out = []
    for n in ast.walk(tree):
        if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs:
            out.append((n.lineno, n.value))
        for field in ("id", "attr", "name", "arg", "asname"):
            if isinstance(getattr(n, field, None), str) and hasattr(n, "lineno"):
                out.append((n.lineno, getattr(n, field)))
    return out


def test_no_code_names_a_robot(repo):
    """Robot facts live in data files and configs (issue 66): no identifier or string in the
    packages names a robot (comments and docstrings may)."""
    models = {p.stem for p in (repo / "mpnet" / "data_files" / "robots").glob("*.yaml")}
    found = []
    for pkg in ("mpnet", "harness"):
        for path in sorted((repo / pkg).rglob("*.py")):
            for line, text in _code_words(path):
                for command in COMMANDS:
                    text = text.replace(command, "")
                low = text.lower()
                if ROBOTS & set(re.split(r"[^a-z0-9]+", low)) or models & set(re.split(r"[^a-z0-9_]+", low)):
                    found.append(f"{path.relative_to(repo)}:{line}: {text[:60]!r}")
    assert not found, "\n".join(found)


def test_no_planner_names_a_checker_class_or_its_private_fields(repo):
    """Planners reach a robot through CollisionChecker's interface only (its compiled form
    included: compiled_env); a robot kind of one's own needs no planner edit."""
    pattern = re.compile(r"\b(?!CollisionChecker\b)\w+Checker\b|\b(checker|raw|c|ch)\._\w")
    hits = [
        f"{p.relative_to(repo)}:{i}: {line.strip()}"
        for p in sorted((repo / "mpnet" / "planners").rglob("*.py"))
        for i, line in enumerate(p.read_text().splitlines(), 1)
        if pattern.search(line)
    ]
    assert hits == []


def test_ruff_clean(repo):
    """Lint and format as configured in pyproject.toml (ruff is a dev dependency)."""
    for args in (["check", "."], ["format", "--check", "."]):
        p = subprocess.run([sys.executable, "-m", "ruff", *args], cwd=repo, capture_output=True, text=True, timeout=120)
        assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-2000:]


def test_architecture_lists_every_module(repo):
    """ARCHITECTURE.md's module map names every module of mpnet/ and harness/ (package
    __init__ files aside), so that a newcomer's map is the code's."""
    text = (repo / "ARCHITECTURE.md").read_text()
    missing = [
        str(p.relative_to(repo))
        for pkg in ("mpnet", "harness")
        for p in sorted((repo / pkg).rglob("*.py"))
        if p.name != "__init__.py" and "__pycache__" not in p.parts and str(p.relative_to(repo / pkg)) not in text
    ]
    assert not missing, f"ARCHITECTURE.md does not list {missing}"


def test_no_package_index_host_in_the_code(repo):
    """Downloads go through pip (the user's index, mirror and proxy), never a hard-coded host."""
    hosts = ("pypi.org", "pythonhosted.org")
    found = [str(p.relative_to(repo)) for p in _sources(repo) if any(h in p.read_text() for h in hosts)]
    assert found == []


def test_no_test_data_is_git_ignored(repo):
    """A clean clone (CI's) has every fixture file the tests read: `*.mcap` was once ignored
    and tests/data/old_logs passed here but not there."""
    files = [str(p.relative_to(repo)) for p in (repo / "tests" / "data").rglob("*") if p.is_file()]
    if not (repo / ".git").exists():
        pytest.skip("not a git checkout")
    cmd = ["git", "check-ignore", "--no-index", "--stdin"]
    p = subprocess.run(cmd, cwd=repo, input="\n".join(files), capture_output=True, text=True)
    assert p.stdout.split() == [], p.stdout


BORROWED_VIEWS = {"unpack", "unpack_buffers", "unpack_obstacles"}  # views without reference counts (mpnet.jit)


def _decorator_options(fn) -> dict:
    """The keyword options of a function's njit(...) decorator, as source text."""
    import ast

    for d in fn.decorator_list:
        if isinstance(d, ast.Call) and getattr(d.func, "id", getattr(d.func, "attr", "")) == "njit":
            return {k.arg: ast.unparse(k.value) for k in d.keywords}
    return {}


def test_the_borrowed_views_are_read_only_by_borrowed_kernels(repo):
    """A borrowed kernel's views carry no reference: a counting kernel would release one it never
    got, Python would get the viewed array's parent. Every read of them sits in a function
    compiled `borrowed=True` that is not inlined into whatever calls it."""
    import ast

    bad = []
    files = _sources(repo) + sorted((repo / "tests").rglob("*.py")) + sorted((repo / "docs").rglob("*.py"))
    for p in files:
        text = p.read_text()
        if not any(view in text for view in BORROWED_VIEWS):  # parsed only where a view is named
            continue
        tree = ast.parse(text, str(p))
        for fn in [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)]:
            reads = [
                n
                for n in ast.walk(fn)
                if isinstance(n, (ast.Name, ast.Attribute))
                and isinstance(n.ctx, ast.Load)
                and (n.id if isinstance(n, ast.Name) else n.attr) in BORROWED_VIEWS
            ]
            opts = _decorator_options(fn)
            if reads and (opts.get("borrowed") != "True" or opts.get("inline") == "'always'"):
                bad.append(f"{p.relative_to(repo)}:{reads[0].lineno} in {fn.name}")
    assert not bad, f"borrowed views read outside a borrowed kernel: {bad}"
