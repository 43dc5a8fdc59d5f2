"""What kind of planner each run is, from the facts its `/run` message logs (harness/log/facts.py:
computed once from the run's resolved config when it started; an older log's from its config text),
never from the planner's name, so that a run keeps its place whatever it is called. Rows and labels
keep the logged planner name; the facts decide which table a row goes to and how it is ordered,
labelled and compared. A run without a readable config is a plain planner (with a warning).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import pandas as pd

from harness.log.facts import run_facts as logged_facts  # a run's facts, for the report's modules
from harness.log.schemas import run_segments
from harness.report.names import (
    ABLATION_BASES,
    ABLATIONS,
    KNOWN_EXTRAS,
    PAPER_PLANNERS,
    PLANNER_LABELS,
    env_rank,
    labelled,
    split_rank,
)

_LABELLED = re.compile(r"(.+) \[([^\[\]]+)\]")  # names.labelled's `planner [label]`
DIRTY_MARK = "†"  # after the label of a planner some of whose runs came from a dirty tree


@dataclass(frozen=True)
class PlannerFacts:
    """What a run's config says its planner is; every field None for a plain planner."""

    base: str | None = None  # mpnet_nr / mpnet_hr: an MPNet run, or the base of an ablation
    variant: str | None = None  # the ablation: random, straight, zeros, nodropout, rrtc ('+' joins several)
    algorithm: str | None = None  # the OMPL algorithm of a classical or time-to-equal-quality run
    target: str | None = None  # nr / hr: whose cost a time-to-equal-quality run must reach
    factor: float | None = None  # ... times this factor

    @property
    def ablation(self) -> tuple[str, str] | None:
        return (self.base, self.variant) if self.base and self.variant else None

    @property
    def equal_quality(self) -> tuple[str, str, float] | None:
        return (self.algorithm, self.target, self.factor) if self.target else None

    def describe(self) -> str:
        if self.equal_quality:
            return f"a time-to-equal-quality run ({self.algorithm} to {self.target}, factor {self.factor:g})"
        if self.ablation:
            return f"an ablation of {self.base} ({self.variant})"
        if self.base:
            return self.base
        return f"a classical planner ({self.algorithm})" if self.algorithm else "a plain planner"


PLAIN = PlannerFacts()


def run_facts(run: dict) -> PlannerFacts | None:
    """The planner facts of one run, None when its config has no `planner` mapping."""
    p = logged_facts(run)["planner"]
    return None if p is None else PlannerFacts(**p)


class Facts:
    """The facts of every planner name in the logs, and what follows from them: a row's place,
    label and comparator. A name it does not know is a plain planner. A labelled name (`bit_star
    [A]`, from `--label A=DIR`) is the logged planner's, compared with planners of its own label."""

    def __init__(
        self,
        by_planner: Mapping[str, PlannerFacts] | None = None,
        tags: Mapping[str, tuple[str, str | None]] | None = None,
        dirty: Mapping[str, list[str]] | None = None,
        recipes: Iterable[str] = (),
    ):
        self.by_planner = dict(by_planner or {})
        self.tags = dict(tags or {})
        self.dirty = dict(dirty or {})  # planner -> the dirty revisions some of its runs came from
        self.recipes = set(recipes)  # names whose label is their networks' recipe (load.recipe_label)

    def mark(self, planner: str) -> str:
        """DIRTY_MARK after a planner any of whose runs came from a dirty tree, else ""."""
        return f" {DIRTY_MARK}" if planner in self.dirty else ""

    def dirty_note(self) -> str:
        """The line under every table that shows a marked planner ("" when none is)."""
        if not self.dirty:
            return ""
        revs = sorted({r for rs in self.dirty.values() for r in rs})
        return (
            f"{DIRTY_MARK} Some runs of this planner come from a dirty tree (uncommitted code: "
            f"{', '.join(revs)}): no revision reproduces them."
        )

    def of(self, planner: str) -> PlannerFacts:
        return self.by_planner.get(planner, PLAIN)

    def tag(self, planner: str) -> tuple[str, str | None]:
        """(the logged planner name, its --label or None) of a shown name; a name no file showed
        (a labelled run's target planner, `mpnet_nr [A]`) is split at its bracketed label."""
        if planner in self.tags:
            return self.tags[planner]
        m = _LABELLED.fullmatch(str(planner))
        return (m.group(1), m.group(2)) if m else (planner, None)

    def ablation(self, planner: str) -> tuple[str, str] | None:
        """(base, variant) for an MPNet ablation, e.g. ("mpnet_nr", "random"), else None; the base
        carries the ablation's label (`mpnet_nr [A]`)."""
        ab = self.of(planner).ablation
        return None if ab is None else (labelled(ab[0], self.tag(planner)[1]), ab[1])

    def equal_quality(self, planner: str) -> tuple[str, str, float] | None:
        """(algorithm, target, factor) for a time-to-equal-quality run, e.g. ("bit_star", "nr", 1.1), else None."""
        return self.of(planner).equal_quality

    def comparator(self, planner: str) -> str | None:
        """The planner a row's significance marks compare with: an ablation's own base (mpnet_nr or
        mpnet_hr), none for mpnet_nr itself, mpnet_nr for every other planner (MPNet (HR) included);
        of the same label; for a recipe-labelled planner, its own_recipe."""
        if planner in self.recipes:
            return self.own_recipe(planner)
        ab = self.ablation(planner)
        if ab is not None:
            return ab[0]
        plain, label = self.tag(planner)
        return None if plain == "mpnet_nr" else labelled("mpnet_nr", label)

    def own_recipe(self, planner: str) -> str | None:
        """A recipe-labelled planner's counterpart on the env's own recipe: the unlabelled planner
        of the same base and variant but the recipe's tags (`mpnet_nr [dagger2]`: mpnet_nr;
        `mpnet_hr_rrtc [paper_recipe]`: mpnet_hr_rrtc); None where the logs have none."""
        pf, label = self.of(planner), self.tag(planner)[1] or ""
        recipe = set(label.split("+"))
        rest = "+".join(v for v in (pf.variant or "").split("+") if v and v not in recipe) or None
        for name, f in self.by_planner.items():
            if self.tag(name)[1] is None and (f.base, f.variant) == (pf.base, rest) and f.target is None:
                return name
        return None

    def rank(self, planner: str) -> tuple:
        """The paper's planners, the known extras, any other planner by name, then the ablations
        (by base, then variant), then the time-to-equal-quality planners; a labelled planner right
        after the unlabelled one (labels by name)."""
        plain, label = self.tag(planner)
        return self._rank(plain, self.of(planner)) + (label or "",)

    @staticmethod
    def _rank(plain: str, pf: PlannerFacts) -> tuple:
        known = PAPER_PLANNERS + KNOWN_EXTRAS
        if plain in known:
            return (0, known.index(plain), "")
        ab = pf.ablation
        if ab is not None:
            variants = list(ABLATIONS)
            v = variants.index(ab[1]) if ab[1] in variants else len(variants)
            return (2, ABLATION_BASES.index(ab[0]) * (len(variants) + 1) + v, plain)
        if pf.equal_quality is not None:
            return (3, 0, plain)
        return (1, 0, plain)

    def label(self, planner: str) -> str:
        plain, label = self.tag(planner)
        return self._label(plain, self.of(planner)) + (f" [{label}]" if label else "") + self.mark(planner)

    @staticmethod
    def _label(plain: str, pf: PlannerFacts) -> str:
        if plain in PLANNER_LABELS:
            return PLANNER_LABELS[plain]
        ab = pf.ablation
        if ab is not None:
            return f"{PLANNER_LABELS[ab[0]]}: {ab[1]}"
        eq = pf.equal_quality
        if eq is not None:
            alg, target, factor = eq
            return f"{PLANNER_LABELS.get(alg, alg)} to {target.upper()}" + (f" ×{factor:g}" if factor != 1.0 else "")
        return plain

    def sort(self, df: pd.DataFrame, cols=("env", "split", "planner")) -> pd.DataFrame:
        """df's rows in report order (envs, splits, then planners as rank orders them)."""
        rank = {"env": env_rank, "split": split_rank, "planner": self.rank}
        if df.empty:
            return df
        order = sorted(range(len(df)), key=lambda i: tuple(rank[c](df[c].iat[i]) for c in cols))
        return df.iloc[order].reset_index(drop=True)


def planner_facts(files: Iterable) -> tuple[Facts, list[str]]:
    """The facts of each planner name, from the first of its files (in path order) whose config has a
    `planner` section; plus one warning line per file whose config has none, or makes the planner
    another ablation or time-to-equal-quality run than that first file does."""
    by: dict[str, PlannerFacts] = {}
    first, no_config, warns, tags, dirty, recipes = {}, [], [], {}, {}, set()
    for tf in files:
        name = tf.planner
        tags[name] = (str(tf.run["planner"]), tf.label)
        if tf.recipe:
            recipes.add(name)
        for seg in run_segments(tf.run):
            rev = str(seg["git_rev"] or "")
            if rev.endswith("-dirty") and rev not in dirty.setdefault(name, []):
                dirty[name].append(rev)
        f = run_facts(tf.run)
        if f is None:
            no_config.append((tf.path, name))
        elif name not in by:
            by[name], first[name] = f, tf.path
        elif (f.ablation, f.equal_quality) != (by[name].ablation, by[name].equal_quality):
            warns.append(
                f"warning: {tf.path}: its config makes {name} {f.describe()}, but {first[name]}'s makes it "
                f"{by[name].describe()}: taken as the latter"
            )
    for path, name in no_config:
        how = f"taken as {first[name]} says ({by[name].describe()})" if name in by else "counted as a plain planner"
        warns.append(f"warning: {path}: its /run has no readable config with a planner section: {name} {how}")
    return Facts(by, tags, {k: v for k, v in dirty.items() if v}, recipes), warns
