"""The pretrained sets shipped in the package: each loads, its weights are the ones its
meta.json records, and its key is the one today's config of that env and scale computes
(a config change that alters the key fails here: regenerate with harness.export_weights).
A set plans exactly as the checkpoint it was exported from, and stands in for it without
the dataset being built."""

import json
from pathlib import Path

import pytest

from mpnet.models import load_pnet_checkpoint
from mpnet.models.pretrained import SHIPPED, export_pretrained, read_meta, write_checkpoint

SETS = sorted(p.parent for p in SHIPPED.glob("*/meta.json"))
# a set of networks other than the env's recipe is named by their tags (ENV-SCALE+TAG): the
# planner whose networks it holds
RECIPE_PLANNERS = {"paper_recipe": "+planner=mpnet_nr_paper"}


def test_every_env_ships_a_quick_set():
    """Each env's own networks; another recipe's set (ENV-SCALE+TAGS) may ship beside them."""
    plain = {p.name for p in SETS if "+" not in p.name}
    assert plain == {f"{e}-quick" for e in ("s2d", "c2d", "c3d", "rigid", "arm7", "panda_mbm")}


def _set_name(cfg):
    from harness.core.settings import settings_of
    from harness.export_weights import _set_name

    run = settings_of(cfg)
    return _set_name(cfg, run, f"{run.env.name}-{run.scale}")


@pytest.mark.parametrize(
    ("overrides", "name"),
    [
        (["+env=panda_mbm"], "panda_mbm-quick"),
        (["+env=panda_mbm", "+planner=mpnet_hr_paper"], "panda_mbm-quick+paper_recipe"),
        (["+env=panda_mbm", "+planner=mpnet_nr_dense"], "panda_mbm-quick"),  # its options are the env's recipe's
        (["+env=s2d", "+planner=mpnet_nr_paper"], "s2d-quick"),  # s2d's recipe is the paper's
        (["+env=s2d", "+planner=mpnet_nr", "+planner.networks.dropout=0.25"], "s2d-quick+dropout0.25"),
    ],
)
def test_a_set_is_named_by_its_networks_not_its_planner(compose_config, overrides, name):
    assert _set_name(compose_config(overrides)) == name


def test_networks_no_tag_tells_apart_are_refused_a_name(compose_config):
    """equal_steps changes the models key and no run label: its set would take the env's name."""
    from harness.core.cli import UsageError

    cfg = compose_config(["+env=panda_mbm", "+planner=mpnet_nr", "+planner.networks.equal_steps=false"])
    with pytest.raises(UsageError, match="planner.networks"):
        _set_name(cfg)


def test_the_docs_name_each_shipped_sets_models_and_paths(repo):
    """docs/mpnet.md's table of shipped sets says which models each was exported from and how
    many expert paths trained it: the sets' own meta.json (a regenerated set fails here until
    the table says so)."""
    import re

    rows = dict(re.findall(r"^\| (\S+-quick\S*) \| (.+) \|$", (repo / "docs" / "mpnet.md").read_text(), re.M))
    assert set(rows) == {p.name for p in SETS}
    for folder in SETS:
        meta = read_meta(folder)
        assert f"`models/{meta['key']}`" in rows[folder.name]
        assert f"{meta['training_paths']:,} expert paths" in rows[folder.name]


@pytest.mark.parametrize("folder", SETS, ids=[p.name for p in SETS])
def test_shipped_set_loads_and_matches_its_key(folder, tmp_path, settings):
    from harness.artifacts.ensure import models_key_config
    from mpnet.data.store import content_key

    meta = read_meta(folder)
    base, *tags = folder.name.split("+")
    env, scale = base.rsplit("-", 1)
    key_config = models_key_config(settings([f"+env={env}", f"scale={scale}", *(RECIPE_PLANNERS[t] for t in tags)]))
    assert meta["config"] == json.loads(json.dumps(key_config))
    assert meta["key"] == content_key({"kind": "models", **key_config})
    write_checkpoint(folder, tmp_path / "pnet.ckpt")  # verifies the weights' sha256
    encode, step = load_pnet_checkpoint(tmp_path / "pnet.ckpt").to_numpy()
    assert step.state_dim == len(meta["hyper_parameters"]["state_scale"])


def test_damaged_set_is_refused(tmp_path):
    from mpnet.models import CheckpointError

    folder = tmp_path / "set"
    folder.mkdir()
    src = SETS[0]
    (folder / "meta.json").write_text((src / "meta.json").read_text())
    data = bytearray((src / "weights.npz").read_bytes())
    data[len(data) // 2] ^= 0xFF  # one byte of the weights flipped
    (folder / "weights.npz").write_bytes(bytes(data))
    with pytest.raises(CheckpointError, match="differs"):
        write_checkpoint(folder, tmp_path / "pnet.ckpt")


@pytest.mark.slow
def test_exported_set_plans_as_its_checkpoint(tmp_path, run_cli, settings, sweeps_cache):
    """Tiny s2d trained, exported, and both planning the tiny test set: the same paths. Other
    networks exported beside it, as docs/mpnet.md exports the paper's recipe for +env=panda_mbm
    (hours of training: s2d's tiny networks stand in; s2d's recipe is the paper's)."""
    from harness.artifacts.ensure import ensure_testset
    from harness.bench.run import runtime_objects
    from mpnet.planners.base import Problem
    from mpnet.planners.mpnet import from_checkpoint

    cache = sweeps_cache  # the session's tiny s2d networks (trained once, by whichever test needs them first)
    args = ["-m", "+env=s2d", "scale=tiny", "progress=false", f"cache_dir={cache}", f"hydra.sweep.dir={tmp_path / 'r'}"]
    out = run_cli("harness.export_weights", *args, f"export_dir={tmp_path / 'sets'}").stdout  # a sweep, as documented
    assert "exported: " in out and (tmp_path / "sets" / "testsets" / "s2d-tiny" / "seen.json").exists()
    models = cache / "models" / read_meta(tmp_path / "sets" / "pretrained" / "s2d-tiny")["key"]  # the set's own
    data = Path(json.loads((models / "manifest.json").read_text())["data_folder"])
    assert models.is_dir() and data.parent == cache / "data"
    built = json.loads((data / "manifest.json").read_text())["expert"]["paths"]
    # other networks go beside the env's, not over them; the paper's recipe is s2d's own (one set)
    for planner in (["+planner=mpnet_nr_paper"], ["+planner=mpnet_nr", "+planner.networks.dropout=0.25"]):
        run_cli("harness.export_weights", *args, *planner, f"export_dir={tmp_path / 'sets'}")
    sets = {p.name: read_meta(p)["key"] for p in (tmp_path / "sets" / "pretrained").iterdir()}
    assert sorted(sets) == ["s2d-tiny", "s2d-tiny+dropout0.25"] and sets["s2d-tiny"] == models.name
    assert sets["s2d-tiny+dropout0.25"] != models.name
    meta = read_meta(tmp_path / "sets" / "pretrained" / "s2d-tiny")
    assert meta["training_paths"] == built > 0
    # the build and training times a doc may quote, with where and at which revision they ran
    assert meta["built"]["data"]["expert"]["paths"] == built and meta["built"]["models"]["build_wall_s"] > 0
    assert {"git_rev", "machine", "created_at"} <= set(meta["built"]["models"]) & set(meta["built"]["data"])
    shipped = tmp_path / "shipped"
    shipped.mkdir()
    write_checkpoint(tmp_path / "sets" / "pretrained" / "s2d-tiny", shipped / "pnet.ckpt")

    run = settings([*args[1:5]])
    spec = run.env.spec
    testset = ensure_testset(run, progress=False)
    cloud = runtime_objects(run)["cloud"]
    problems = [
        Problem(spec, ws, spec.make_checker(ws), q.start, q.goal, seed=i)
        for ws in testset.workspaces
        for i, q in enumerate(testset.queries)
        if (q.split, q.workspace_id) == (ws.split, ws.id)
    ]
    paths = [
        [from_checkpoint(f, spec, 0, cloud, name="mpnet_hr", hybrid=True).solve(p, 2.0).path for p in problems]
        for f in (models, shipped)
    ]
    assert len(problems) == 8 and any(p is not None for p in paths[0])
    assert paths[0] == paths[1]


def test_export_refuses_non_float32(tmp_path):
    import torch

    from mpnet.models import CheckpointError

    torch.save({"hyper_parameters": {}, "state_dict": {"pnet.w": torch.zeros(2, dtype=torch.float64)}}, tmp_path / "c")
    with pytest.raises(CheckpointError, match="float32"):
        export_pretrained(tmp_path / "c", tmp_path / "out", "k", {})


@pytest.mark.slow
def test_bench_plans_on_the_shipped_set_without_building_the_dataset(tmp_path, run_cli, problems_dir):
    cache = tmp_path / "cache"
    p = run_cli(
        "harness",
        "+env=rigid",
        "+planner=mpnet_nr",
        f"problems={problems_dir / 'rigid.json'}",
        f"cache_dir={cache}",
        "rerun=false",
        "progress=false",
        f"hydra.run.dir={tmp_path / 'r'}",
    )
    assert "models: the shipped pretrained set rigid-quick" in p.stderr
    assert sorted(d.name for d in cache.iterdir()) == ["pretrained"]  # no dataset, no training
