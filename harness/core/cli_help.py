"""`--help` of the Hydra entry points: a usage line, the choices of each config group, the
main keys with their meaning (the comments of conf/*.yaml) and examples. Hydra's own help
says 'Compose your configuration ... (group=option)', the wrong syntax for the groups added
with `+`; it stays reachable as `--hydra-help`."""

from __future__ import annotations

import re
import textwrap
from dataclasses import dataclass
from pathlib import Path

CONF_DIR = Path(__file__).resolve().parents[2] / "conf"
ENVS = sorted(p.stem for p in (CONF_DIR / "env").glob("*.yaml"))  # every env, for examples that name them all
ADDED = ("env", "planner", "experiment")  # the groups without a default: +group=NAME


@dataclass(frozen=True)
class Entry:
    usage: str
    about: str
    config: str  # the config file Hydra composes (conf/<config>.yaml)
    groups: tuple[str, ...]  # config groups listed with their choices
    keys: tuple[str, ...]  # dotted keys listed with their comments from conf/
    examples: tuple[str, ...]


_BENCH_KEYS = ("seed", "budget_s", "splits", "problems", "problems_per_set", "rerun", "resume", "progress", "cache_dir")

ENTRIES = {
    "harness": Entry(
        "python -m harness +env=ENV +planner=PLANNER [scale=S] [KEY=VALUE ...] [-m]",
        "Run one planner on one env's test queries; writes trials.mcap, queries.csv and trials.rrd to the run dir.",
        "config",
        ("env", "planner", "scale", "experiment", "hydra/launcher"),
        _BENCH_KEYS,
        (
            "python -m harness +env=s2d +planner=bit_star scale=tiny",
            "python -m harness +env=c2d +planner=mpnet_nr seed=1 budget_s=5 hydra.run.dir=runs/c2d",
            "python -m harness -m +experiment=table1 scale=quick",
        ),
    ),
    "harness.data": Entry(
        "python -m harness.data +env=ENV [scale=S] [KEY=VALUE ...] [-m]",
        "Build an env's training data and test sets into the cache (done on first use by the bench otherwise).",
        "data",
        ("env", "scale", "hydra/launcher"),
        ("jobs", "cache_dir", "shards", "shard", "merge", "progress"),
        (
            "python -m harness.data +env=s2d scale=tiny",
            "python -m harness.data scale=quick -m +env=s2d,c2d,c3d,rigid",
            "python -m harness.data +env=s2d scale=tiny shards=3 hydra/launcher=local -m 'shard=range(0,3)'",
        ),
    ),
    "harness.train": Entry(
        "python -m harness.train +env=ENV [scale=S] [train.KEY=VALUE ...] [-m]",
        "Train an env's Enet and Pnet into the cache (built data first when missing).",
        "config",
        ("env", "scale", "hydra/launcher"),
        (
            "train.seed",
            "train.lr",
            "train.optimizer",
            "train.fused",
            "train.lam",
            "train.patience",
            "train.accelerator",
            "train.devices",
            "cache_dir",
        ),
        (
            "python -m harness.train +env=s2d scale=tiny",
            "python -m harness.train +env=c3d scale=quick train.optimizer=adam train.lr=0.001",
            "python -m harness.train scale=tiny hydra/launcher=local -m +env=s2d,c2d",
        ),
    ),
    "harness.export_weights": Entry(
        "python -m harness.export_weights +env=ENV [scale=S] [export_dir=DIR] [-m]",
        "Write an env's trained networks and test set (built first if missing) as the sets a fresh clone plans on.",
        "export",
        ("env", "scale"),
        ("export_dir", "cache_dir"),
        (
            "python -m harness.export_weights +env=s2d scale=quick",
            f"python -m harness.export_weights -m +env={','.join(ENVS)} scale=quick",
            "python -m harness.export_weights +env=s2d scale=tiny export_dir=/tmp/sets",
        ),
    ),
    "harness.overhead": Entry(
        "python -m harness.overhead +env=ENV +planner=PLANNER [scale=S] [KEY=VALUE ...]",
        "What the harness costs per query beside the planner, from a real bench run.",
        "config",
        ("env", "planner", "scale"),
        _BENCH_KEYS,
        (
            "python -m harness.overhead +env=s2d +planner=bit_star scale=tiny",
            "python -m harness.overhead +env=c2d +planner=mpnet_nr scale=quick",
            "python -m harness.overhead +env=s2d +planner=rrt_connect scale=tiny splits=[seen]",
        ),
    ),
    "harness.perf": Entry(
        "python -m harness.perf [perf=default|tiny] [perf.KEY=VALUE ...] [out=DIR]",
        "Every speed figure of the benchmark in one run: OUT/perf.md, OUT/perf.csv, OUT/figures/perf_*.png.",
        "perf_main",
        ("perf",),
        (
            "out",
            "cache_dir",
            "perf.scale",
            "perf.envs",
            "perf.planners",
            "perf.splits",
            "perf.budget_s",
            "perf.network_sizes",
        ),
        (
            "python -m harness.perf perf=tiny out=/tmp/perf",
            "python -m harness.perf perf.envs=[s2d,c2d] perf.planners=[mpnet_nr,bit_star]",
            "python -m harness.perf perf.budget_s=5 out=reports/perf",
        ),
    ),
}

_LINE = re.compile(r"^(?P<indent> *)(?P<key>[A-Za-z_]\w*):(?P<value>[^#]*)(?:#\s*(?P<comment>.*))?$")


def key_comments(*files: Path, prefix: str = "") -> dict[str, tuple[str, str]]:
    """{dotted key: (its value, its end-of-line comment)} of YAML files written two spaces an indent."""
    out: dict[str, tuple[str, str]] = {}
    for f in files:
        parents: list[str] = []
        for line in f.read_text().splitlines():
            m = _LINE.match(line)
            if not m:
                continue
            depth = len(m["indent"]) // 2
            parents = parents[:depth] + [m["key"]]
            out[prefix + ".".join(parents)] = (m["value"].strip(), (m["comment"] or "").strip())
    return out


def group_choices(groups: tuple[str, ...]) -> dict[str, list[str]]:
    """Each group's options as Hydra sees them (conf/ and the installed plugins' launchers)."""
    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    with initialize_config_dir(str(CONF_DIR), version_base="1.3"):
        loader = GlobalHydra.instance().config_loader()
        return {g: loader.get_group_options(g) for g in groups}


def help_text(prog: str) -> str:
    e = ENTRIES[prog]
    options = group_choices(e.groups)
    comments = {
        **key_comments(CONF_DIR / "config.yaml", CONF_DIR / f"{e.config}.yaml"),
        **key_comments(CONF_DIR / "perf" / "default.yaml", prefix="perf."),
    }
    width = 34
    added = [g for g in e.groups if g in ADDED]
    lines = [
        f"usage: {e.usage}",
        "",
        e.about,
        "",
        "config groups"
        + (
            ":" if not added else f" ({', '.join('+' + g for g in added)} are added with +; the others have a default):"
        ),
    ]
    for g in e.groups:
        head = f"  {'+' if g in ADDED else ''}{g}="
        lines += textwrap.wrap(", ".join(options[g]), 100, initial_indent=f"{head:<18}", subsequent_indent=" " * 18)
    own = (
        "; the chosen env's and planner's own keys are env.KEY and planner.KEY, see conf/" if "env" in e.groups else ""
    )
    lines += ["", f"keys (KEY=VALUE{own}):"]
    for k in e.keys:
        value, comment = comments.get(k, ("", ""))
        head = f"  {k}={value}"
        lines += (
            [head, f"{'':<{width}}{comment}"]
            if len(head) > width - 2 and comment
            else [f"{head:<{width}}{comment}".rstrip()]
        )
    lines += ["", "examples:", *(f"  {x}" for x in e.examples), ""]
    lines += [
        "-m sweeps comma-separated values (seed=0,1,2). Hydra's own flags: --cfg job (print the composed",
        "config), --info, --hydra-help (Hydra's help). README.md has the full story.",
    ]
    return "\n".join(lines)
