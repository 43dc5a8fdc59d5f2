"""Every config composes and builds its objects (env, planners, cost-target hook) without
planning: env x planner at the default scale, every scale, and every experiment's grid."""

from __future__ import annotations

import copy
import dataclasses
import itertools

import pytest
from omegaconf import open_dict

from harness.bench.run import runtime_objects
from harness.core.cli import UsageError, choices
from harness.core.settings import settings_of
from mpnet.envs.specs import generated, get_spec
from mpnet.models import Enet, Pnet
from mpnet.planners.base import Planner
from mpnet.planners.compiled.planner import supports
from mpnet.planners.mpnet import MPNetSettings
from tests.conftest import REPO_ROOT

ENVS, PLANNERS, SCALES, EXPERIMENTS = (choices(g) for g in ("env", "planner", "scale", "experiment"))
FILES_ONLY = [e for e in ENVS if e not in generated()]  # problem files only, robots not installed here
ENVS = [e for e in ENVS if e in generated()]


@pytest.fixture(scope="module")
def models_dirs(tmp_path_factory, write_pnet_checkpoint):
    """A tiny Pnet checkpoint per state dimension (its workspace's dimension beside it), in
    the layout the reader expects."""
    out = {}
    for dim, wdim in ((2, 2), (3, 3), (7, 3)):
        folder = tmp_path_factory.mktemp(f"models{dim}")
        enet, pnet = Enet(10 * wdim, (8,), 4), Pnet(4 + 2 * dim, dim, (8,))
        write_pnet_checkpoint(folder / "pnet.ckpt", enet, pnet, [20.0] * dim, [20.0])
        out[dim] = folder
    return out


def build(cfg, models_dirs) -> list[Planner]:
    """What a bench job builds before planning: the checked config, the env, the planners."""
    run = settings_of(cfg)
    runtime = {**runtime_objects(run), "models_dir": models_dirs[run.env.spec.state_dim]}
    planners = [run.planner.make(runtime)]
    if run.planner.cost_target is not None:
        planners.append(run.planner.cost_target.make(runtime))
    for p in planners:
        assert isinstance(p, Planner) and p.name
    return planners


@pytest.fixture(scope="module")
def env_configs(compose_config) -> dict:
    """Each env config composed once (with a planner, which the pairs below replace)."""
    return {env: compose_config([f"+env={env}", "+planner=bit_star"]) for env in ENVS}


@pytest.fixture(scope="module")
def planner_configs(compose_config) -> dict:
    """Each planner config's section, composed once."""
    return {planner: compose_config(["+env=s2d", f"+planner={planner}"]).planner for planner in PLANNERS}


@pytest.mark.parametrize("env,planner", list(itertools.product(ENVS, PLANNERS)))
@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_every_env_and_planner_builds(env, planner, env_configs, planner_configs, models_dirs):
    """The pair as `+env=ENV +planner=PLANNER` composes it: the groups are independent, so the
    env's composition with the planner's section put in is the same config (interpolations
    resolve against the new root; checked equal for every pair when this was written), at a
    sixth of the cost of composing each of the pairs."""
    cfg = copy.deepcopy(env_configs[env])
    with open_dict(cfg):
        cfg.planner = copy.deepcopy(planner_configs[planner])
    if cfg.planner.get("compiled") and not supports(get_spec(env), cfg.env.collision):  # refused, naming the key
        with pytest.raises(UsageError, match="config key planner.compiled: env"):
            build(cfg, models_dirs)
        return
    (main, *_) = build(cfg, models_dirs)
    assert main.name == cfg.planner.name


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_envs_of_problem_files_only_say_what_they_lack(run_cli, mbm_dir):
    """mbm_ur5 and mbm_fetch: their robots' files are installed by harness.fetch_mbm (the suite's
    robot folder is empty), so `python -m harness +env=mbm_ur5 +planner=rrt_connect problems=...`
    (and mbm_fetch's with +planner=rrt_connect_compiled) says in one line which command installs them."""
    assert set(FILES_ONLY) == {"mbm_ur5", "mbm_fetch"}
    for env, planner in (("mbm_ur5", "rrt_connect"), ("mbm_fetch", "rrt_connect_compiled")):
        p = run_cli("harness", f"+env={env}", f"+planner={planner}", f"problems={mbm_dir}", check=False)
        robot = env.removeprefix("mbm_")
        assert p.returncode != 0 and len(p.stderr.strip().splitlines()) == 1, p.stderr
        assert f"is in no robot folder (python -m harness.fetch_mbm data/mbm --robot {robot})" in p.stderr


@pytest.mark.parametrize("scale", SCALES)
@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_every_scale_builds(scale, compose_config, models_dirs):
    for env in ENVS:
        cfg = compose_config([f"+env={env}", "+planner=mpnet_hr", f"scale={scale}"])
        assert cfg.scale.name in SCALES
        if cfg.env.get("scales") is not None and scale not in cfg.env.scales:  # no sizes of its own there
            with pytest.raises(UsageError, match=f"config key scale: env {env} has its sizes at scales"):
                build(cfg, models_dirs)
            continue
        build(cfg, models_dirs)


def _grid(params: dict) -> list[list[str]]:
    """The sweep's jobs that cover every value of every swept key once, the other keys at their
    first values (every env x planner pair is test_every_env_and_planner_builds's; seeds build
    the same objects)."""
    values = {k: str(v).split(",") for k, v in params.items() if k != "seed"}
    first = {k: v[0] for k, v in values.items()}
    jobs = {tuple(sorted({**first, k: v}.items())) for k, vs in values.items() for v in vs}
    return [[f"{k}={v}" for k, v in job] for job in sorted(jobs)]


@pytest.mark.parametrize("experiment", EXPERIMENTS)
@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_every_experiment_builds(experiment, compose_config, models_dirs):
    """The experiment's sweep (its jobs covering each swept value: _grid), or the experiment alone
    with an env and a planner."""
    hydra_cfg = compose_config([f"+experiment={experiment}", "+env=s2d", "+planner=mpnet_nr"], return_hydra_config=True)
    params = dict(hydra_cfg.hydra.sweeper.params or {})
    jobs = _grid(params) if params else [["+env=s2d", "+planner=mpnet_nr"]]
    for job in jobs:
        build(compose_config([f"+experiment={experiment}", *job]), models_dirs)


def test_a_bad_planner_setting_is_one_line_naming_the_key(compose_config, models_dirs):
    for override, key in (
        ("planner.stop=bogus", "planner.stop"),
        ("planner.proposal=bogus", "planner.proposal"),
        ("planner.steer_steps=[0.0]", "planner.steer_steps"),
    ):
        planner = "bit_star" if "stop" in override else "mpnet_nr"
        cfg = compose_config(["+env=s2d", f"+planner={planner}", override])
        with pytest.raises(UsageError, match=key):
            build(cfg, models_dirs)


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_a_planners_networks_are_checked_and_change_only_their_own_models_key(settings):
    from harness.artifacts.ensure import models_key_config

    for override, key in (
        ("+planner.networks.bogus=1", "planner.networks.bogus"),
        ("planner.networks.waypoint_step=-1", "planner.networks.waypoint_step"),
        ("planner.networks.equal_steps=yes", "planner.networks.equal_steps"),
        ("+planner.networks.dropout=1.0", "planner.networks.dropout"),
        ("+planner.networks.dropout=true", "planner.networks.dropout"),
        ("+planner.networks.bounded=1", "planner.networks.bounded"),
    ):
        with pytest.raises(UsageError, match=key):
            settings(["+env=panda_mbm", "+planner=mpnet_nr_dense", override])
    plain, dense = (
        models_key_config(settings(["+env=panda_mbm", f"+planner={p}"])) for p in ("mpnet_nr", "mpnet_nr_dense")
    )
    assert dense == {**plain, "waypoint_step": 0.5, "equal_steps": True}
    assert models_key_config(settings(["+env=panda_mbm", "+planner=mpnet_hr_dense"])) == dense
    recipe = [
        "+planner.networks.bounded=true",
        "+planner.networks.bidirectional=false",
        "+planner.networks.dropout=0.1",
    ]
    options = models_key_config(settings(["+env=panda_mbm", "+planner=mpnet_nr", *recipe]))
    assert options == {**plain, "bounded": True, "bidirectional": False, "dropout": 0.1}
    voxels = models_key_config(settings(["+env=panda_mbm", "+planner=mpnet_nr", "+planner.networks.voxels=16"]))
    assert voxels == {**plain, "voxels": 16}


def test_a_voxel_encoder_is_refused_where_enet_is_an_autoencoder(settings):
    """Only an end-to-end fit trains a voxel Enet (it has no decoder): s2d's scales pretrain
    Enet as the paper's autoencoder, so the option is one line naming the key; a grid of one
    cell is refused too."""
    with pytest.raises(UsageError, match="networks.voxels.*end to end"):
        settings(["+env=s2d", "+planner=mpnet_nr", "+planner.networks.voxels=8"])
    with pytest.raises(UsageError, match="planner.networks.voxels: expected an integer >= 2"):
        settings(["+env=arm7", "+planner=mpnet_nr", "+planner.networks.voxels=1"])


def test_a_planners_network_options_name_its_variant():
    from harness.log.facts import planner_facts

    nets = {"waypoint_step": 0.5, "bounded": True, "bidirectional": False, "dropout": 0.1, "voxels": 16}
    facts = planner_facts({"hybrid": False, "replanning": "original", "networks": nets})
    assert facts["base"] == "mpnet_nr" and facts["variant"] == "dense+bounded+forward+dropout0.1+voxels16"


@pytest.mark.parametrize("env", ["s2d", "arm7"])
def test_the_validation_step_is_in_the_cache_keys_when_changed(env, compose_config):
    """It decides which expert paths are kept and the reference costs: a data set built at
    another step must not be reused."""
    default = compose_config([f"+env={env}", "+planner=mpnet_nr"])
    same = compose_config([f"+env={env}", "+planner=mpnet_nr", f"env.validation_step={default.env.validation_step}"])
    finer = compose_config(
        [f"+env={env}", "+planner=mpnet_nr", f"env.validation_step={default.env.validation_step / 2}"]
    )
    keys = [settings_of(c).data.key_config() for c in (default, same, finer)]
    assert keys[0] == keys[1] != keys[2]


def test_uniform_expert_pairs_are_another_dataset_and_only_for_the_expert(settings):
    """env.expert.pairs=uniform (arm7's recipe on panda_mbm's scenes): the data key says so (the
    default's key is as before), the test set keeps the env's own queries, a bogus value is one
    line naming the key."""
    from mpnet.data.expert import PAIRS
    from mpnet.envs.spec import random_pairs

    plain, uniform = (settings(["+env=panda_mbm", *o]) for o in ([], ["env.expert.pairs=uniform"]))
    assert "expert_pairs" not in plain.data.key_config()
    assert uniform.data.key_config() == {**plain.data.key_config(), "expert_pairs": "uniform"}
    assert uniform.env.reference_params() == plain.env.reference_params()
    assert PAIRS["uniform"](plain.env.spec) is random_pairs
    assert PAIRS["env"](plain.env.spec) == plain.env.spec.pairs != random_pairs
    with pytest.raises(UsageError, match="env.expert.pairs"):
        settings(["+env=panda_mbm", "env.expert.pairs=bogus"])


def test_scenes_per_batch_is_a_scale_key_in_the_models_key_only_where_set(settings):
    """scale.fit.scenes_per_batch (Pnet's batches drawn from a few scenes each) is a key a
    command can set (it was read but not declared: `+scale.fit...` was refused as unknown);
    unset, the networks' key is what it was."""
    from harness.artifacts.ensure import models_key_config

    plain = models_key_config(settings(["+env=panda_mbm", "+planner=mpnet_nr"]))
    grouped = models_key_config(settings(["+env=panda_mbm", "+planner=mpnet_nr", "scale.fit.scenes_per_batch=2"]))
    assert "scenes_per_batch" not in plain and grouped == {**plain, "scenes_per_batch": 2}
    with pytest.raises(UsageError, match="^config key scale.fit.scenes_per_batch"):
        settings(["+env=s2d", "+planner=mpnet_nr", "scale.fit.scenes_per_batch=0"])


def test_fused_is_in_the_models_and_enets_keys_only_where_set(settings, compose_config):
    """train.fused (torch's fused optimiser step: other rounding, other networks) is in the
    networks' key, and the autoencoder's, where set; unset, both keys are what they were."""
    from harness.artifacts.ensure import models_key_config
    from harness.core.config import enet_params, model_params

    plain = models_key_config(settings(["+env=panda_mbm", "+planner=mpnet_nr"]))
    fused = models_key_config(settings(["+env=panda_mbm", "+planner=mpnet_nr", "train.fused=true"]))
    assert "fused" not in plain and fused == {**plain, "fused": True}
    s2d = model_params(compose_config(["+env=s2d", "+planner=mpnet_nr", "train.fused=true"]))
    assert enet_params(s2d)["fused"] is True and "fused" not in enet_params(model_params(compose_config(["+env=s2d"])))


def test_the_experts_run_budget_is_in_the_data_key_and_only_rrt_connects(settings):
    """env.expert.run_iterations (panda_mbm's): in the data key where set, absent where not (the
    datasets built before it keep their keys); the test set's reference is unchanged; with the
    rrt_star expert it is one line naming the key."""
    mbm, other = (settings(["+env=panda_mbm", *o]) for o in ([], ["env.expert.run_iterations=5000"]))
    assert mbm.data.key_config()["expert_run_iterations"] == 20000
    assert other.data.key_config() == {**mbm.data.key_config(), "expert_run_iterations": 5000}
    assert other.env.reference_params() == mbm.env.reference_params()
    assert "expert_run_iterations" not in settings(["+env=arm7"]).data.key_config()
    with pytest.raises(UsageError, match="^config key env.expert.run_iterations: the rrt_connect"):
        settings(["+env=s2d", "+env.expert.run_iterations=5"])
    with pytest.raises(UsageError, match="^config key env.expert.run_iterations: expected"):
        settings(["+env=panda_mbm", "env.expert.run_iterations=0"])
    # the compiled expert: another dataset (its planner in the key), the same budget and range
    compiled = settings(["+env=panda_mbm", "env.expert.planner=rrt_connect_compiled"]).data.key_config()
    assert compiled == {**mbm.data.key_config(), "expert_planner": "rrt_connect_compiled"}


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_an_envs_recipe_is_every_mpnet_planners_unless_it_asks_for_the_papers(settings):
    """env.networks is the env's default recipe: under every planner's own options key by key;
    `recipe: paper` trains on the env's paper_networks, or the scale's own where it has none;
    sizes and min_waypoints are checked. (arm7 carries neither recipe; panda_mbm both.)"""
    from harness.artifacts.ensure import models_key_config

    def key(*o, env="arm7"):
        return models_key_config(settings([f"+env={env}", *o]))

    mbm = key("+planner=mpnet_nr", env="panda_mbm")
    assert {k: mbm.get(k) for k in ("bounded", "waypoint_step", "equal_steps", "dropout")} == {
        "bounded": True,
        "waypoint_step": 0.5,
        "equal_steps": True,
        "dropout": 0.1,
    }
    mbm_paper = key("+planner=mpnet_nr_paper", env="panda_mbm")
    assert mbm_paper == key("+planner=mpnet_nr", "+planner.networks.recipe=paper", env="panda_mbm")
    assert (mbm_paper["bidirectional"], mbm_paper["min_waypoints"], mbm_paper["latent"]) == (False, 10, 60)
    assert "bounded" not in mbm_paper and mbm_paper["dropout"] == 0.5  # the scale's: the paper's rate

    plain = key("+planner=mpnet_nr")
    env = ["+env.networks.bounded=true", "+env.networks.dropout=0.2"]
    assert key("+planner=mpnet_nr", *env) == {**plain, "bounded": True, "dropout": 0.2}
    dense = key("+planner=mpnet_nr_dense")
    assert key("+planner=mpnet_nr_dense", *env) == {**dense, "bounded": True, "dropout": 0.2}
    paper = ["+planner.networks.recipe=paper", "+planner.networks.min_waypoints=10", "+planner.networks.latent=60"]
    assert key("+planner=mpnet_nr", *env, *paper) == {**plain, "min_waypoints": 10, "latent": 60}
    arm = ["+env.paper_networks.bidirectional=false", "+env.paper_networks.min_waypoints=10"]
    assert key("+planner=mpnet_nr", *env, *arm, "+planner.networks.recipe=paper") == {
        **plain,
        "bidirectional": False,
        "min_waypoints": 10,
    }
    sized = key("+planner=mpnet_nr", "+planner.networks.pnet_hidden=[64,32]")
    assert sized == {**plain, "pnet_hidden": [64, 32]}
    for bad, name in (
        ("+planner.networks.recipe=mine", "planner.networks.recipe"),
        ("+planner.networks.min_waypoints=1", "planner.networks.min_waypoints"),
        ("+planner.networks.pnet_hidden=[64,0]", "planner.networks.pnet_hidden"),
        ("+env.networks.bogus=1", "env.networks.bogus"),
    ):
        with pytest.raises(UsageError, match=name):
            settings(["+env=arm7", "+planner=mpnet_nr", bad])


@pytest.mark.parametrize("planner", ["mpnet_nr", "mpnet_hr"])
def test_the_mpnet_configs_spell_out_the_librarys_defaults(planner, compose_config):
    """MPNet's defaults are written once, in the library (NeuralSettings, MPNetSettings); the
    configs repeat them because a run logs its config's settings and a resumed run is held to
    them, so here they are held equal: only the label, HR's hybrid and the compiled loop (the
    configs' choice) differ; clip, newer than the logs, is left to the default."""
    defaults = {f.name: f.default for f in dataclasses.fields(MPNetSettings) if f.default is not dataclasses.MISSING}
    section = compose_config(["+env=s2d", f"+planner={planner}"]).planner  # not every config's: the fast loop
    spelled = {k: section[k] for k in section if k in defaults}
    expected = {k: v for k, v in defaults.items() if k != "clip"} | {"hybrid": planner == "mpnet_hr", "compiled": True}
    assert spelled == expected


def test_every_recipe_option_is_checked_against_its_schema_entry():
    """The recipe's options are one typed schema (harness.core.schema): each takes a value of
    its type within its bounds, and refuses another type, or a value out of bounds, in one
    line naming the key; docs/mpnet.md names every option."""
    from omegaconf import OmegaConf

    from harness.core.config import _networks
    from harness.core.schema import OPTIONS

    good = {bool: True, int: 4, float: 0.5, list: [64, 32]}
    bad = {bool: 1, int: 1.5, float: "x", list: [64, 0], str: "bogus"}
    for f in OPTIONS:
        kind, name = f.metadata["kind"], f"env.networks.{f.name}"
        value = f.metadata["choices"][-1] if f.metadata["choices"] else good[kind]
        ok = _networks(OmegaConf.create({f.name: value}), "env.networks")
        assert ok == {f.name: value} and type(ok[f.name]) is kind, f.name
        for value in (bad[kind], *((f.metadata["minimum"] - 1,) if f.metadata["minimum"] is not None else ())):
            with pytest.raises(UsageError, match=f"^config key {name}: expected"):
                _networks(OmegaConf.create({f.name: value}), "env.networks")
    docs = (REPO_ROOT / "docs" / "mpnet.md").read_text(encoding="utf-8")
    assert [f.name for f in OPTIONS if f"`{f.name}`" not in docs and f"`{f.name}:" not in docs] == []


def test_the_goal_pairs_choices_are_the_librarys():
    """The recipe's goal_pairs takes what mpnet.models.pairs.waypoint_pairs does."""
    from harness.core.schema import OPTIONS
    from mpnet.models.pairs import GOALS

    assert next(f for f in OPTIONS if f.name == "goal_pairs").metadata["choices"] == GOALS


def test_every_env_knob_is_checked_against_its_schema_entry(compose_config):
    """conf/env's knobs are typed by harness.core.schema.EnvKnobs: panda_mbm's config (which
    has every knob) conforms, and a wrong value of each is one line naming its key."""
    from harness.core.config import check_env
    from harness.core.schema import EnvKnobs, ExpertKnobs

    env = compose_config(["+env=panda_mbm", "+planner=bit_star"]).env
    check_env(env)
    bad = {float: -1.0, int: 0, bool: "yes", str: "bogus"}
    for schema, where in ((EnvKnobs, "env"), (ExpertKnobs, "env.expert")):
        for f in dataclasses.fields(schema):
            if "section" in f.metadata:
                continue
            node = copy.deepcopy(env)
            section = node if where == "env" else node.expert
            assert f.name in section, f"panda_mbm's config lacks {where}.{f.name}"
            with open_dict(section):
                section[f.name] = bad[f.metadata["kind"]]
            with pytest.raises(UsageError, match=f"^config key {where}.{f.name}: expected"):
                check_env(node)


def test_an_absent_expert_knob_has_one_default(compose_config):
    """The expert's defaults are written once (mpnet.settings.EXPERT): an env's `expert:` that
    leaves a knob out (s2d names no planner, pairs or check) builds its data with it, the
    schema holds it, and the logs' facts fill it in for a config that omits it."""
    from harness.core.schema import ExpertKnobs
    from harness.core.settings import settings_of
    from harness.log.facts import facts_from_config
    from mpnet.settings import EXPERT

    cfg = compose_config(["+env=s2d", "+planner=bit_star"])
    absent = [f.name for f in dataclasses.fields(EXPERT) if f.name not in cfg.env.expert]
    assert {"planner", "pairs", "check"} <= set(absent)
    data = settings_of(cfg).data
    for name in absent:
        assert getattr(data, f"expert_{name}") == getattr(EXPERT, name), name
    schema = {f.name: f.default for f in dataclasses.fields(ExpertKnobs)}
    assert {n: schema[n] for n in dataclasses.asdict(EXPERT)} == dataclasses.asdict(EXPERT)
    assert facts_from_config({"env": {"expert": {}}})["expert_planner"] == EXPERT.planner
