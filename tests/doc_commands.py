"""The documented commands read from the text alone (tests/test_docs.py): each fenced shell
block's commands, normalised and parsed, what a test that runs one must mention, and a test's
text by its id."""

from __future__ import annotations

import ast
import functools
import re
import shlex
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


DOC_FILES = ("README.md", "docs/*.md")  # docs/research/ is not read: it quotes others' values
SHELL_FENCES = {"", "bash", "sh", "shell", "console"}
COMMAND = re.compile(
    r"^(?:[A-Za-z_]\w*=\S*\s+)*"  # environment assignments: PYTHONPATH=$E
    r"(?:srun\s(?:.*?\s)?)?"  # a launcher prefix: srun -p cpu -c 32
    r"(?:python -m |pip install |jupyter )"
)


def commands_in(markdown: str) -> list[str]:
    """The commands of `markdown`'s shell code blocks, normalised (see the module docstring)."""
    found, fence, pending = [], None, ""
    for line in markdown.splitlines():
        stripped = line.strip()
        if stripped.startswith("```"):
            fence = stripped[3:].strip().lower() if fence is None else None
            pending = ""
            continue
        if fence not in SHELL_FENCES:
            continue
        text = pending + stripped
        if text.endswith("\\"):
            pending = text[:-1].rstrip() + " "
            continue
        pending = ""
        text = re.sub(r"(?:^|\s)#.*$", "", text).strip()
        for part in re.split(r"\s*&&\s*", text):
            part = " ".join(part.split())
            if COMMAND.match(part):
                found.append(part)
    return found


def documented_commands() -> list[tuple[str, str]]:
    """(file, command) for every command of README.md and docs/*.md, in page order."""
    files = [p for pattern in DOC_FILES for p in sorted(REPO.glob(pattern))]
    return [(p.relative_to(REPO).as_posix(), c) for p in files for c in commands_in(p.read_text())]


def parse(command: str) -> tuple[list[str], list[str], str | None, list[str]]:
    """(environment names, program words, module of `python -m` or None, arguments) of a
    command, its placeholders `<...>` made one word and its optional `[...]` groups dropped."""
    text = re.sub(r"<[^>]*>", "PLACEHOLDER", command)
    text = re.sub(r"(?:^|(?<=\s))\[[^\]]*\]", "", text)
    words = shlex.split(text)
    env = []
    while words and re.match(r"^[A-Za-z_]\w*=", words[0]):
        env.append(words.pop(0).split("=", 1)[0])
    while words and words[0] not in ("python", "pip", "jupyter"):  # srun and its options
        words.pop(0)
    if words[:2] == ["python", "-m"]:
        return env, words[:2], words[2], words[3:]
    return env, words[:2], None, words[2:]


# Keys whose values a test substitutes: sizes, seeds, paths, caches and run folders.
FREE_KEYS = {
    "scale",
    "seed",
    "shard",
    "jobs",
    "budget_s",
    "progress",
    "cache_dir",
    "problems",
    "problems_per_set",
    "out",
    "export_dir",
    "hydra.run.dir",
    "hydra.sweep.dir",
}


def _placeholder(value: str) -> bool:
    return bool(re.search(r"[$<]|PLACEHOLDER|path/to", value)) or bool(re.fullmatch(r"[A-Z_]+", value))


def _word(value: str) -> str:
    return r"(?<!\w)" + re.escape(value) + r"(?!\w)"


def _sweep(value: str) -> list[str]:
    """A swept value's choices (`s2d,c2d`), or [] for one value (lists and calls are one)."""
    return value.split(",") if "," in value and not re.search(r"[\[\]{}()]", value) else []


def required_mentions(command: str) -> list[tuple[str, list[str]]]:
    """What the text of a test that runs `command` must mention: (what, regexes any one of
    which must match). The rules:

    - the module of `python -m M` (`"harness"`, `harness.report`), as a whole dotted name;
    - each environment variable the command sets (`PYTHONPATH`, `MPNET_FIGURE`);
    - `-m` (or `--multirun`) when the command sweeps, as a quoted argument;
    - each option (`--paper`, `--label`); an option's value is not checked;
    - each `key=value` / `+key=value` override, unless its key is one a test substitutes
      (FREE_KEYS: scale, seed, paths, caches, run folders, jobs): `key=value` as written, or
      `key=` with the value as a word (a parametrised `f"+env={env}"`); a swept value
      (`+env=s2d,c2d`) needs `key=` and any one of its choices, since a test sweeps a few; a
      placeholder value (`ENV`, `$CACHE`, `<date>`) needs `key=` only;
    - positional arguments (run folders, files) and optional `[...]` groups are not checked.
    """
    env, _, module, args = parse(command)
    needs = [(f"module {module}", [r"(?<![\w.])" + re.escape(module) + r"(?![\w.])"])] if module else []
    needs += [(f"environment variable {name}", [re.escape(name)]) for name in env]
    after_option = False
    for arg in args:
        if arg in ("-m", "--multirun"):
            needs.append(("-m (a sweep)", [r"""["'](?:-m|--multirun)["']"""]))
        elif arg.startswith("-"):
            needs.append((arg.split("=")[0], [re.escape(arg.split("=")[0])]))
            after_option = arg.startswith("--") and "=" not in arg
            continue
        elif "=" in arg and not after_option:
            key, value = arg.split("=", 1)
            if key.lstrip("+") in FREE_KEYS or _placeholder(key):
                pass
            elif _placeholder(value):
                needs.append((f"{key}=", [re.escape(key + "=")]))
            elif choices := _sweep(value):
                needs.append((f"{key}=", [re.escape(key + "=")]))
                needs.append((f"one of {key}={value}", [_word(c) for c in choices]))
            else:
                either = [re.escape(arg)]
                if re.fullmatch(r"[A-Za-z_][\w.]*", value) and value not in ("true", "false", "null"):
                    either.append(f"(?s){re.escape(key + '=')}.*{_word(value)}|{_word(value)}.*{re.escape(key + '=')}")
                needs.append((arg, either))
        after_option = False
    return list(dict(needs).items())  # each once, in order


@functools.cache
def _functions(test_file: str) -> dict[str, str]:
    """name -> source text (decorators included) of a test file's top-level functions."""
    path = REPO / test_file
    if not path.is_file():
        return {}
    source = path.read_text()
    lines = source.splitlines()
    out = {}
    for node in ast.parse(source).body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            start = min([node.lineno, *(d.lineno for d in node.decorator_list)])
            out[node.name] = "\n".join(lines[start - 1 : node.end_lineno])
    return out


def source_of_test(test_id: str) -> str | None:
    """The text of the test `tests/file.py::name`, or None where there is no such test."""
    file, _, name = test_id.partition("::")
    return _functions(file).get(name)
