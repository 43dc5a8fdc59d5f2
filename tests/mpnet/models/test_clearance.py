"""The collision loss (planner.networks.collision_loss, issue 42): the sphere checker's spheres posed
in torch, the signed distance of each primitive at known points, a depth that is zero wherever the
checker sees no obstacle contact and pushes a proposal out of an obstacle, and the option's keys."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from harness.core.cli import UsageError
from harness.log.facts import network_variant
from mpnet import models  # its LightningModules load on first use, not as pytest collects
from mpnet.envs.checkers.spheres import sphere_model
from mpnet.envs.scenes.generators import make_workspaces
from mpnet.envs.specs import get_spec
from mpnet.models import Enet, Pnet
from mpnet.models.clearance import Clearance, _ball_distance, _box_distance, _cylinder_distance, _near, _posed


@pytest.fixture(scope="module")
def panda():
    spec = get_spec("panda_mbm")
    workspaces = make_workspaces(spec, list(range(6)), "train", 0)
    model = sphere_model(spec.robot.model.name)
    return spec, workspaces, model, Clearance(spec.robot.clearance_arrays(workspaces))


@pytest.mark.slow  # the Panda's scenes and sphere model: seconds to build
def test_the_checkers_spheres_are_posed_in_torch(panda):
    """Forward kinematics in torch gives the compiled model's sphere centres (the root link's left out)."""
    _, _, model, clearance = panda
    q = np.random.default_rng(0).uniform(model.lower, model.upper, (50, model.model.dof))
    got = clearance.spheres(torch.tensor(q, dtype=torch.float32)).numpy()
    keep = model.sphere_link >= model.first
    want = np.stack([model.world_spheres(x)[keep, :3] for x in q])
    assert got.shape == want.shape and np.abs(got - want).max() < 1e-5


def test_each_primitives_signed_distance_at_known_points():
    """Box (turned a quarter about z), capped cylinder and ball: outside, on a face, inside."""
    turn = [0, 1, 0, -1, 0, 0, 0, 0, 1]  # the rotation's columns: x -> y, y -> -x
    box = torch.tensor([1.0, 0, 0, *turn, 0.5, 0.1, 0.2])  # half sizes along its own axes
    pts = torch.tensor([[1.0, 0.0, 0.0], [1.0, 0.7, 0.0], [1.3, 0.0, 0.0], [2.0, 1.0, 0.0]])
    want = [-0.1, 0.2, 0.2, np.hypot(0.9, 0.5)]
    assert np.allclose(_box_distance(pts, box.expand(4, 15)).numpy(), want, atol=1e-5)
    cyl = torch.tensor([0.0, 0, 0, 0, 0, 1, 0.5, 1.0])  # radius 0.5, half height 1 along z
    pts = torch.tensor([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.5], [1.5, 0.0, 2.0]])
    want = [-0.5, 0.5, 0.5, np.hypot(1.0, 1.0)]
    assert np.allclose(_cylinder_distance(pts, cyl.expand(4, 8)).numpy(), want, atol=1e-5)
    ball = torch.tensor([0.0, 1, 0, 0.25])
    assert np.allclose(_ball_distance(torch.tensor([[0.0, 1, 0], [0, 2, 0]]), ball.expand(2, 4)).numpy(), [-0.25, 0.75])


@pytest.mark.slow  # the Panda's scenes and sphere model: seconds to build
def test_only_groups_that_touch_are_measured_and_nothing_is_missed(panda):
    """The groups' bounding spheres select which spheres are measured: the depth equals every
    sphere against every obstacle (the oracle below), value and gradient."""
    _, workspaces, model, clearance = panda
    rng = np.random.default_rng(3)
    q = torch.tensor(rng.uniform(model.lower, model.upper, (300, model.model.dof)), dtype=torch.float32)
    ws = torch.as_tensor(rng.integers(0, len(workspaces), len(q)))
    a, b = q.clone().requires_grad_(True), q.clone().requires_grad_(True)
    fast, every = clearance.penetration(a, ws), _every_sphere(clearance, b, ws)
    assert (every > 0).sum() > 15 and torch.allclose(fast, every, atol=1e-5)
    fast.sum().backward()
    every.sum().backward()
    assert torch.allclose(a.grad, b.grad, atol=1e-4)


def _every_sphere(clearance: Clearance, q: torch.Tensor, ws: torch.Tensor) -> torch.Tensor:
    c, r = clearance.spheres(q).unsqueeze(2), clearance.radius[None, :, None]
    kinds = (
        (clearance.boxes, _box_distance),
        (clearance.cylinders, _cylinder_distance),
        (clearance.balls, _ball_distance),
    )
    return sum(torch.relu(r - f(c, obstacles[ws].unsqueeze(1))).sum((1, 2)) for obstacles, f in kinds)


@pytest.mark.slow  # the Panda's scenes and sphere model: seconds to build
def test_the_groups_screen_finds_every_touching_group_in_order(panda):
    """_near (the exact distance only where a group's and an obstacle's bounding spheres meet)
    gives the (state, group, obstacle) triples that testing every triple gives, in the same
    order (the depth's sum then adds in the same order: the same bits)."""
    _, workspaces, model, clearance = panda
    rng = np.random.default_rng(5)
    q = torch.tensor(rng.uniform(model.lower, model.upper, (400, model.model.dof)), dtype=torch.float32)
    ws = torch.as_tensor(rng.integers(0, len(workspaces), len(q)))
    groups = _posed(*clearance._frames(q), clearance.group_frame, clearance.group_local)
    found = 0
    for obstacles, reach, distance in zip(
        (clearance.boxes, clearance.cylinders, clearance.balls),
        clearance.reach,
        (_box_distance, _cylinder_distance, _ball_distance),
    ):
        mine = obstacles[ws]
        every = (distance(groups.unsqueeze(2), mine.unsqueeze(1)) < clearance.group_radius[None, :, None]).nonzero()
        got = torch.stack(_near(groups, clearance.group_radius, mine, reach[ws], distance), 1)
        assert torch.equal(got, every)
        found += len(every)
    assert found > 100


@pytest.mark.slow  # the Panda's scenes and sphere model: seconds to build
def test_the_depth_is_zero_where_the_checker_sees_no_contact_and_pushes_out(panda):
    """Every configuration the sphere checker calls free has depth 0 (the same spheres, the same
    primitives); many it blocks have a positive depth (the rest collide with the arm itself);
    a step down the depth's gradient makes it smaller."""
    spec, workspaces, model, clearance = panda
    rng = np.random.default_rng(1)
    q = rng.uniform(model.lower, model.upper, (600, model.model.dof))
    ws = rng.integers(0, len(workspaces), len(q))
    depth = clearance.penetration(torch.tensor(q, dtype=torch.float32), torch.as_tensor(ws)).numpy()
    checkers = [spec.make_checker(w) for w in workspaces]
    free = np.array([checkers[w].is_valid(x) for w, x in zip(ws, q)])
    assert free.sum() > 50 and (~free).sum() > 50
    assert np.all(depth[free] == 0.0)
    assert (depth[~free] > 0).sum() > 30
    deep = torch.tensor(q[depth > 0.05][:20], dtype=torch.float32, requires_grad=True)
    rows = torch.as_tensor(ws[depth > 0.05][:20])
    before = clearance.penetration(deep, rows)
    before.sum().backward()
    after = clearance.penetration(deep.detach() - 1e-3 * deep.grad / deep.grad.norm(dim=1, keepdim=True), rows)
    assert torch.all(after <= before.detach() + 1e-6) and torch.any(after < before.detach())


def _scales(model) -> dict:
    """A bounded PnetModule's normalisers for the arm's joint bounds."""
    return {
        "state_scale": [float(v) for v in (model.upper - model.lower) / 2],
        "state_offset": [float(v) for v in (model.upper + model.lower) / 2],
        "cloud_scale": 1.0,
    }


@pytest.mark.slow  # the Panda's scenes and sphere model: seconds to build
def test_the_loss_needs_its_scenes_and_is_saved_with_the_module(panda):
    """A module with a collision loss refuses a batch it cannot place in a scene, adds the
    weighted depth where it can (the hyper-parameter saved), and a negative weight is refused."""
    spec, workspaces, model, clearance = panda
    dof = model.model.dof
    torch.manual_seed(0)
    kw = _scales(model)
    net = models.PnetModule(
        Pnet(4 + 2 * dof, dof, (16, 8), dropout=0.0, bounded=True), Enet(30, (16,), 4), collision_loss=10.0, **kw
    )
    plain = models.PnetModule(Pnet(4 + 2 * dof, dof, (16, 8), dropout=0.0, bounded=True), Enet(30, (16,), 4), **kw)
    plain.load_state_dict(net.state_dict())
    q = torch.tensor(np.random.default_rng(2).uniform(model.lower, model.upper, (8, dof)), dtype=torch.float32)
    batch = {"clouds": torch.randn(2, 30), "ws": torch.tensor([0, 1] * 4), "wsid": torch.tensor([3, 4])}
    batch |= {"x_t": q, "x_goal": q.flip(0), "x_next": q}
    with pytest.raises(ValueError, match="attach_clearance"):
        net.batch_loss(batch, stochastic=False)
    net.attach_clearance(clearance)
    with torch.no_grad():
        mse = plain.batch_loss(batch, stochastic=False)[0]
        total = net.batch_loss(batch, stochastic=False)[0]
        pred = net.state_norm.denormalize(
            net.pnet.step(
                net.encode(batch["clouds"])[batch["ws"]],
                *(net.state_norm.normalize(batch[k]) for k in ("x_t", "x_goal")),
                False,
            )
        )
        depth = clearance.penetration(pred[:2], torch.tensor([3, 4])).mean()
    assert torch.isclose(total, mse + 10.0 * depth)
    assert net.hparams["collision_loss"] == 10.0 and "collision_loss" not in plain.hparams
    with pytest.raises(ValueError, match="collision_loss"):
        models.PnetModule(Pnet(4 + 2 * dof, dof, (16, 8)), Enet(30, (16,), 4), collision_loss=-1.0, **kw)


@pytest.mark.slow  # the Panda's scenes and sphere model: seconds to build
def test_collision_motion_measures_states_along_the_step(panda):
    """collision_motion m: the depth is the mean over the states at 1/m ... m/m of the straight
    step from x_t to the proposal (m = 1: the proposal alone, today's loss, and no hyper-parameter
    saved); a count below 1 or a bool is refused."""
    spec, workspaces, model, clearance = panda
    dof = model.model.dof
    torch.manual_seed(0)
    kw = {**_scales(model), "collision_loss": 10.0}

    def module(**more):
        torch.manual_seed(0)
        net = models.PnetModule(
            Pnet(4 + 2 * dof, dof, (16, 8), dropout=0.0, bounded=True), Enet(30, (16,), 4), **kw, **more
        )
        net.attach_clearance(clearance)
        return net

    one, three = module(), module(collision_motion=3)
    plain = models.PnetModule(Pnet(4 + 2 * dof, dof, (16, 8), dropout=0.0, bounded=True), Enet(30, (16,), 4),
                       **{k: v for k, v in kw.items() if k != "collision_loss"})  # fmt: skip
    plain.load_state_dict(one.state_dict())
    q = torch.tensor(np.random.default_rng(5).uniform(model.lower, model.upper, (8, dof)), dtype=torch.float32)
    batch = {"clouds": torch.randn(2, 30), "ws": torch.tensor([0, 1] * 4), "wsid": torch.tensor([3, 4])}
    batch |= {"x_t": q, "x_goal": q.flip(0), "x_next": q}
    with torch.no_grad():
        mse = plain.batch_loss(batch, stochastic=False)[0]
        pred = one.state_norm.denormalize(
            one.pnet.step(
                one.encode(batch["clouds"])[batch["ws"]],
                *(one.state_norm.normalize(batch[k]) for k in ("x_t", "x_goal")),
                False,
            )
        )[:2]
        ws = torch.tensor([3, 4])
        along = [clearance.penetration(q[:2] + t * (pred - q[:2]), ws) for t in (1 / 3, 2 / 3, 1.0)]
        assert torch.isclose(one.batch_loss(batch, stochastic=False)[0], mse + 10.0 * along[-1].mean())
        assert torch.isclose(three.batch_loss(batch, stochastic=False)[0], mse + 10.0 * torch.stack(along).mean())
    assert "collision_motion" not in one.hparams and three.hparams["collision_motion"] == 3
    for bad in (0, True, 1.5):
        with pytest.raises(ValueError, match="collision_motion"):
            module(collision_motion=bad)


@pytest.mark.slow  # composes panda_mbm (its URDF read): seconds
def test_the_option_is_a_models_key_a_variant_and_the_arms_only(settings):
    """It changes the networks (models key), not the data; logs name it; a robot with no sphere
    model (s2d's point) gets one line naming the key."""
    from harness.artifacts.ensure import models_key_config

    plain = settings(["+env=panda_mbm", "+planner=mpnet_nr"])
    weighted = settings(["+env=panda_mbm", "+planner=mpnet_nr", "+planner.networks.collision_loss=5"])
    assert plain.data.key_config() == weighted.data.key_config()
    assert models_key_config(weighted) == {**models_key_config(plain), "collision_loss": 5.0}
    assert network_variant({"collision_loss": 5.0}) == ["collision5"]
    with pytest.raises(
        UsageError, match="^config key networks.collision_loss .*env s2d's robot offers no collision loss"
    ):
        settings(["+env=s2d", "+planner=mpnet_nr", "+planner.networks.collision_loss=1"])
    with pytest.raises(UsageError, match="planner.networks.collision_loss"):
        settings(["+env=panda_mbm", "+planner=mpnet_nr", "+planner.networks.collision_loss=-1"])
    moving = settings(["+env=panda_mbm", "+planner=mpnet_nr", "+planner.networks.collision_motion=4"])
    assert models_key_config(moving) == {**models_key_config(plain), "collision_motion": 4}
    assert network_variant({"collision_loss": 0.01, "collision_motion": 4}) == ["collision0.01", "motion4"]
    assert network_variant({"collision_loss": 0.01, "collision_motion": 1}) == ["collision0.01"]
    with pytest.raises(UsageError, match="^config key networks.collision_motion .*collision_loss is not set"):
        settings(["+env=panda_mbm", "+planner=mpnet_nr", "+planner.networks.collision_loss=0",
                  "+planner.networks.collision_motion=4"])  # fmt: skip
    with pytest.raises(UsageError, match="planner.networks.collision_motion"):
        settings(["+env=panda_mbm", "+planner=mpnet_nr", "+planner.networks.collision_motion=0"])
