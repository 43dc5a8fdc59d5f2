"""Artifacts a stage needs, built on first use with the same code as the explicit stage.

Every load verifies the files against the manifest's checksums (mpnet.data.store); a
damaged artifact is rebuilt with a warning on stderr, and one that cannot be rebuilt here
is refused with one line (RunRefused: exit status 1) naming it."""

from __future__ import annotations

import json
import sys
import time
from functools import partial
from pathlib import Path

from tqdm import tqdm

from harness.artifacts.dagger import with_dagger
from harness.core.cli import RunRefused, UsageError
from harness.core.config import enet_params
from harness.core.provenance import artifact_provenance
from harness.core.settings import RunSettings
from mpnet.data.dataset import build_dataset, build_expert_shard, load_dataset, reusable, seed_chunks
from mpnet.data.expert import chunks_of
from mpnet.data.queries import make_testset
from mpnet.data.shipped import copy_testset, find_testset
from mpnet.data.store import ArtifactError, content_key, ensure, partial_dir, read_manifest
from mpnet.envs.scenes.generators import env_split_ids, make_workspaces
from mpnet.envs.spec import TestSet
from mpnet.envs.workspace import Workspace
from mpnet.planners.reference import describe, reference_costs
from mpnet.problems import ProblemFileError, dump_problems, load_problems
from mpnet.settings import EXPERT


def _made(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _bar(total: int, desc: str, progress: bool):
    """A stage's progress bar on stderr, one tick per workspace."""
    return tqdm(total=total, desc=desc, unit="workspace", file=sys.stderr, disable=not progress, dynamic_ncols=True)


def _warn(message: str) -> None:
    print(f"warning: {message}", file=sys.stderr)


def _ensure(root, kind: str, config: dict, build, provenance, check):
    """store.ensure with damaged artifacts reported on stderr and one that cannot be
    rebuilt as the user's one line."""
    try:
        return ensure(root, kind, config, build, provenance, check=check, notify=_warn)
    except ArtifactError as e:
        raise RunRefused(str(e)) from None


def _check_sizes(folder: Path, sizes: dict) -> None:
    """A legacy manifest's recorded file sizes (it has no checksums)."""
    for name, size in sizes.items():
        got = (folder / name).stat().st_size
        if got != size:
            raise ArtifactError(f"{folder / name}: {got} bytes, the manifest says {size}")


def _check_dataset(folder: Path, manifest: dict) -> None:
    from mpnet.data.dataset import DATA_FILE

    if "bytes" in manifest:
        _check_sizes(folder, {DATA_FILE: manifest["bytes"]})
    load_dataset(folder, manifest)


def _testset_check(spec):
    def check(folder: Path, manifest: dict) -> None:
        for name in manifest["files"]:
            try:
                load_problems(folder / name, spec)
            except ProblemFileError as e:
                raise ArtifactError(str(e)) from None

    return check


def _check_models(folder: Path, manifest: dict) -> None:
    from harness.artifacts.fit import ENET_FILE
    from mpnet.models.checkpoint import load_enet_checkpoint, load_pnet_checkpoint

    _check_sizes(folder, manifest.get("fit", {}).get("bytes", {}))
    for name in manifest["files"]:
        try:
            (load_enet_checkpoint if name == ENET_FILE else load_pnet_checkpoint)(folder / name)
        except ValueError as e:
            raise ArtifactError(str(e)) from None


def ensure_dataset(run: RunSettings, progress: bool = True, plan: bool = True):
    """The env's training dataset at this scale, from the cache or built now: (folder,
    manifest, built); `load_dataset(folder, manifest)` reads it. plan=False: the merge of
    a sharded build, which plans nothing (MissingChunks when a shard has not finished)."""
    spec, params = run.env.spec, _data(run)

    def build(folder: Path) -> dict:
        bar = _bar(params.train_workspaces, f"expert paths {spec.name}", progress)
        try:
            resume = partial_dir(run.cache_dir, "data", params.key_config())  # a build cut short resumes
            _reuse_chunks(run.cache_dir, params, resume)
            return build_dataset(spec, params, folder, jobs=run.jobs, progress=bar.update, resume_dir=resume, plan=plan)
        finally:
            bar.close()

    return _ensure(run.cache_dir, "data", params.key_config(), build, artifact_provenance, _check_dataset)


def _reuse_chunks(root, params, resume: Path) -> None:
    """Datasets of one config and other sizes (a learning curve's, a grown scale's) share
    their first chunks of expert paths: take them from the cached ones instead of planning
    them again."""
    for manifest_path in sorted(Path(root, "data").glob("*/manifest.json")):
        try:
            manifest = read_manifest(manifest_path.parent, manifest_path.parent.name)
        except ArtifactError:
            continue
        if manifest.get("kind") == "data" and reusable(params, manifest.get("config", {})):
            n = seed_chunks(params, load_dataset(manifest_path.parent, manifest), resume)
            if n:
                print(f"expert paths: {n} chunks from the dataset {manifest_path.parent}", file=sys.stderr)


def dataset_shard(run: RunSettings, shard: int, shards: int, progress: bool = True):
    """Plan shard `shard` of `shards` of the dataset's expert paths into its partial folder
    in the cache (a cluster job; the merge assembles the dataset). Returns (the dataset's
    folder, None) when it is built already, else (the partial folder, the shard's paths)."""
    spec, params = run.env.spec, run.data
    key_config = params.key_config()
    folder = run.cache_dir / "data" / content_key({"kind": "data", **key_config})
    try:
        read_manifest(folder, folder.name)
        return folder, None
    except ArtifactError:
        pass
    resume = partial_dir(run.cache_dir, "data", key_config)
    total = sum(len(c) for c in chunks_of(params.train_workspaces, params.expert_chunk, (shard, shards)).values())
    with _bar(total, f"expert paths {spec.name} shard {shard}/{shards}", progress) as bar:
        paths = build_expert_shard(spec, params, resume, (shard, shards), jobs=run.jobs, progress=bar.update)
    return resume, paths


TESTSET_FORMAT = "mpnet-bench/testset@2"  # @2: reference costs


def testset_key_config(run: RunSettings) -> dict:
    """What the test set artifact's key hashes."""
    key_config = {
        "format": TESTSET_FORMAT,
        "env": run.env.spec.name,
        "data_seed": run.env.data_seed,
        "solvable_s": run.env.solvable_s,
        "splits": {s: list(v) for s, v in run.test_sizes.items()},
        "reference": dict(run.reference),
        **({"geometry": dict(run.env.geometry)} if run.env.geometry else {}),
    }
    if not run.test_blocked_only:  # only then in the key: existing sets keep theirs
        key_config["blocked_only"] = False
    return key_config


def ensure_testset_artifact(run: RunSettings, progress: bool = True):
    """The scale's generated test set, both splits, as problem files in the cache: copied
    from the package's shipped set of its key (mpnet.data.shipped), or built now; returns
    (folder, manifest, built)."""
    spec = run.env.spec
    key_config = testset_key_config(run)
    sizes = dict(run.test_sizes)
    for split, (count, _) in sizes.items():
        _check_ids(spec, split, count, f"scale.test.{split}.workspaces")

    def build(folder: Path) -> dict:
        from ompl import util as ou

        source = find_testset(content_key({"kind": "testset", **key_config}))
        if source is not None:
            print(f"test set: the shipped set {source.name}", file=sys.stderr)
            try:
                return copy_testset(source, folder)
            except ArtifactError as e:
                raise RunRefused(str(e)) from None

        ou.setLogLevel(ou.LOG_WARN)  # RRT-Connect's solvability checks would flood stdout
        with _bar(sum(n for n, _ in sizes.values()), f"test set {spec.name}", progress) as bar:
            ts = make_testset(
                spec, sizes, run.env.data_seed, run.env.solvable_s, bar.update, blocked_only=run.test_blocked_only
            )
        t0 = time.perf_counter()
        with _bar(len(ts.workspaces), f"reference costs {spec.name}", progress) as bar:
            reference_costs(
                spec,
                ts.workspaces,
                ts.queries,
                **key_config["reference"],
                seed=run.env.data_seed,
                jobs=run.jobs,
                progress=bar.update,
            )
        ref_s = time.perf_counter() - t0
        for split in sizes:
            dump_problems(folder / f"{split}.json", ts, split=split)
        return {
            "format": TESTSET_FORMAT,
            "files": [f"{s}.json" for s in sizes],
            "queries": {s: sum(q.split == s for q in ts.queries) for s in sizes},
            "reference": {
                "method": describe(spec, key_config["reference"].get("expert", EXPERT.planner)),
                "seconds": ref_s,
            },
        }

    return _ensure(run.cache_dir, "testset", key_config, build, artifact_provenance, _testset_check(spec))


def ensure_testset(run: RunSettings, progress: bool = True):
    """The splits the run asks for of the scale's test set (ensure_testset_artifact), as one TestSet."""
    spec = run.env.spec
    folder, _, _ = ensure_testset_artifact(run, progress)
    workspaces, queries = [], []
    for split in run.splits:
        part = load_problems(folder / f"{split}.json", spec)
        for item in (*part.workspaces, *part.queries):
            item.split = split
        workspaces += part.workspaces
        queries += part.queries
    return TestSet(spec, workspaces, queries)


def _check_enet(folder: Path, manifest: dict) -> None:
    from harness.artifacts.fit import ENET_FILE
    from mpnet.models.checkpoint import load_enet_checkpoint

    try:
        load_enet_checkpoint(folder / ENET_FILE)
    except ValueError as e:
        raise ArtifactError(str(e)) from None


def _data(run: RunSettings):
    """The run's data params; UsageError for an env with no data (no workspace generator)."""
    if run.data is None:
        raise UsageError(
            f"config key planner: env {run.env.name} has no workspace generator, so no data to train networks on "
            "(planners without networks plan its problem files)"
        )
    _check_ids(run.env.spec, "seen", run.data.train_workspaces, "scale.train.workspaces")
    for split, (count, _) in run.test_sizes.items():  # before the dataset's hours, not after
        _check_ids(run.env.spec, split, count, f"scale.test.{split}.workspaces")
    return run.data


def _check_ids(spec, split: str, count: int, key: str) -> None:
    """A count of workspaces the env's generator can make for the split (UsageError naming the key)."""
    try:
        env_split_ids(spec, split, count)
    except ValueError as e:
        raise UsageError(f"config key {key}: env {spec.name}: {e}") from None


def models_key_config(run: RunSettings) -> dict:
    """What the models artifact's key hashes: the dataset's key (derived from its params,
    so that a cached or shipped model needs no dataset built) and the training params."""
    data_key = content_key({"kind": "data", **_data(run).key_config()})
    return {"data": data_key, **run.models}


def training_paths(run: RunSettings) -> int | None:
    """How many expert paths the run's networks were trained on: the count in the dataset's
    manifest (in the cache), else in the shipped set's meta; None when neither says (a set
    exported before the count was). The scale's workspaces x paths is what was asked: an env
    whose queries can fail (panda_mbm's cage goals) builds fewer."""
    from mpnet.models.pretrained import find_pretrained, read_meta

    key_config = models_key_config(run)
    folder = run.cache_dir / "data" / key_config["data"]
    try:
        return int(read_manifest(folder, folder.name, verify=False)["expert"]["paths"])
    except (ArtifactError, KeyError, TypeError, ValueError):
        pass
    source = find_pretrained(content_key({"kind": "models", **key_config}))
    try:
        n = None if source is None else read_meta(source).get("training_paths")
    except ValueError:
        return None
    return int(n) if isinstance(n, int) else None


def _shipped_models(run: RunSettings, key_config: dict):
    """The package's pretrained set for these models, as a checkpoint in the cache (kind
    "pretrained"), when the cache has no models artifact of this key; else None."""
    from harness.artifacts.fit import PNET_FILE
    from mpnet.models.pretrained import find_pretrained, read_meta, write_checkpoint

    key = content_key({"kind": "models", **key_config})
    if (run.cache_dir / "models" / key).exists():
        return None
    source = find_pretrained(key)
    if source is None:
        return None
    try:
        weights = read_meta(source)["weights"]
    except ValueError as e:
        raise RunRefused(str(e)) from None

    def build(folder: Path) -> dict:
        try:
            write_checkpoint(source, folder / PNET_FILE)
        except ValueError as e:
            raise RunRefused(str(e)) from None
        print(f"models: the shipped pretrained set {source.name} (key {key})", file=sys.stderr)
        return {"files": [PNET_FILE], "models_key": key, "source": str(source)}

    return _ensure(run.cache_dir, "pretrained", {"models": key, "weights": weights}, build, artifact_provenance, None)


def ensure_models(run: RunSettings, progress: bool = True, planning: bool = False):
    """The env's trained Enet and Pnet at this scale: from the cache, or trained now
    (building the dataset first if it is missing). Enet's autoencoder is cached on its
    own first, so that Ctrl-C during Pnet keeps it and the same command resumes at Pnet.
    planning: only Pnet's checkpoint is wanted (encoder and Pnet, no decoder), so the
    package's pretrained set for this key serves when the cache lacks the models."""
    lightning, spec, params = run.lightning, run.env.spec, run.models
    key_config = models_key_config(run)
    if planning and (shipped := _shipped_models(run, key_config)) is not None:
        return shipped
    enet_config = enet_params(params)
    data_folder = run.cache_dir / "data" / key_config["data"]

    def build(folder: Path) -> dict:
        from harness.artifacts.fit import fit_enet, fit_models

        _, data_manifest, _ = ensure_dataset(run, progress)
        try:
            data = load_dataset(data_folder, data_manifest)
        except ArtifactError as e:  # damaged since it was verified: the user's one line, not a traceback
            raise RunRefused(str(e)) from None
        if params.get("dagger_rounds"):  # the recipe option: the paths labelled from the rollouts too
            data = with_dagger(run, data, progress, ensure_models)
        resume = _made(partial_dir(run.cache_dir, "models", key_config))  # each finished epoch: a fit cut short goes on
        scenes = partial(training_scenes, run.cache_dir, spec, data)  # a collision loss's scenes, drawn once
        if enet_config is None:
            return fit_models(spec, data, params, lightning, folder, progress, resume=resume, scenes=scenes)
        enet_key_config = {"data": key_config["data"], **enet_config}
        enet_resume = partial_dir(run.cache_dir, "enet", enet_key_config)
        enet_folder, enet_manifest, built = _ensure(
            run.cache_dir,
            "enet",
            enet_key_config,
            lambda f: fit_enet(spec, data, params, lightning, f, progress, _made(enet_resume)),
            provenance,
            _check_enet,
        )
        if not built:
            print(f"Enet: cached in {enet_folder}; training Pnet", file=sys.stderr)
        try:
            enet = (enet_folder, enet_manifest)
            return fit_models(spec, data, params, lightning, folder, progress, enet, resume, scenes)
        except KeyboardInterrupt as e:
            pnet = f"; {e}" if str(e) else "; the same command resumes at Pnet"
            raise KeyboardInterrupt(f"Enet is kept in {enet_folder}{pnet}") from None

    provenance = lambda: {**artifact_provenance(), "data_folder": str(data_folder)}
    return _ensure(run.cache_dir, "models", key_config, build, provenance, _check_models)


SCENES_FILE = "scenes.json"


def training_scenes(root: Path, spec, data) -> list[Workspace]:
    """A dataset's training workspaces in its order, from the cache (kind "scenes", keyed by
    the dataset's key and its scene ids), else drawn and kept there. Why: a collision loss
    measures Pnet's proposals in them, and drawing a scene again costs its screen (MBM's: IK
    for a valid query, ~0.1 s a scene: minutes at thousands of scenes, before every fit and
    every resume of one)."""
    ids = [int(i) for i in data.train_ids]
    config = {"data": data.manifest["key"], "ids": content_key({"ids": ids})}

    def build(folder: Path) -> dict:
        made = make_workspaces(spec, ids, "train", int(data.manifest["config"]["data_seed"]))
        (folder / SCENES_FILE).write_text(json.dumps([w.obstacles_json() for w in made]))
        return {"files": [SCENES_FILE], "scenes": len(made)}

    folder, _, _ = _ensure(root, "scenes", config, build, artifact_provenance, None)
    kept = json.loads((folder / SCENES_FILE).read_text())
    return [Workspace.from_json(str(i), "train", obstacles, spec.workspace_dim) for i, obstacles in zip(ids, kept)]
