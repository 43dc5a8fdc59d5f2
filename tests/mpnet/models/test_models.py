"""MPNet's networks, their numpy export, the LightningModules and DataModules."""

import math
import subprocess
import sys

import lightning as L
import numpy as np
import pytest
import torch
import torch.nn.functional as F
from hypothesis import given, settings
from hypothesis import strategies as st

import mpnet.models.networks as networks
from mpnet.models import (
    PNET_HIDDEN,
    CloudDataModule,
    ContractiveAE,
    Decoder,
    Enet,
    EnetModule,
    MPNetDataModule,
    Normalizer,
    Pnet,
    PnetModule,
    enet_numpy,
    load_enet_checkpoint,
    load_pnet_checkpoint,
    paper_s2d,
    pnet_numpy,
    resample_path,
    split_indices,
    waypoint_pairs,
)

SCALES_2D = {"state_scale": [20.0, 20.0], "cloud_scale": 20.0}  # the s2d bounds: [-20, 20]^2


def _linear_sizes(pnet: Pnet) -> list[int]:
    return [pnet.linears[0].in_features] + [lin.out_features for lin in pnet.linears]


# --------------------------------------------------------------------------- shapes


def test_paper_s2d_shapes():
    enet, dec, pnet = paper_s2d()
    cloud = torch.randn(3, 2800)
    z = enet(cloud)
    assert z.shape == (3, 28)
    assert dec(z).shape == (3, 2800)
    assert [m.out_features for m in enet.linears()] == [512, 256, 128, 28]
    assert [m.out_features for m in dec.net if isinstance(m, torch.nn.Linear)] == [128, 256, 512, 2800]
    assert _linear_sizes(pnet) == [32, 1280, 1024, 896, 768, 512, 384, 256, 256, 128, 64, 32, 2]
    assert len(pnet.acts) == 11 and pnet.p == 0.5
    assert 3.7e6 < sum(p.numel() for p in pnet.parameters()) < 3.9e6
    out = pnet.step(z, torch.randn(3, 2), torch.randn(3, 2))
    assert out.shape == (3, 2)


def test_small_shapes_and_config_round_trip():
    enet = Enet(60, (16, 8), 4)
    dec = Decoder.mirror(enet)
    pnet = Pnet(4 + 2 * 3, 3, (16, 8))
    assert enet(torch.randn(5, 60)).shape == (5, 4)
    assert dec(torch.randn(5, 4)).shape == (5, 60)
    assert pnet(torch.randn(5, 10)).shape == (5, 3)
    assert pnet(torch.randn(10)).shape == (3,)
    for net, cls in ((enet, Enet), (dec, Decoder), (pnet, Pnet)):
        again = cls(**net.config())
        assert again.config() == net.config()
        again.load_state_dict(net.state_dict())
    with pytest.raises(ValueError):
        ContractiveAE(enet, Decoder(61, (16, 8), 4))
    with pytest.raises(ValueError):
        Pnet(10, 3, (16,), dropout=1.0)


def test_dropout_after_every_hidden_layer_but_the_last(monkeypatch):
    widths = []
    real = F.dropout

    def spy(x, p=0.5, training=True, inplace=False):
        widths.append((x.shape[-1], p, training))
        return real(x, p, training, inplace)

    monkeypatch.setattr(networks.F, "dropout", spy)
    pnet = Pnet(32, 2)
    pnet(torch.randn(1, 32), stochastic=True)
    assert widths == [(w, 0.5, True) for w in PNET_HIDDEN[:-1]]  # none after 64 -> 32
    widths.clear()
    pnet(torch.randn(1, 32), stochastic=False)
    assert widths == []


# --------------------------------------------------------------------------- dropout


def test_dropout_follows_the_argument_not_the_module_mode():
    torch.manual_seed(0)
    pnet = Pnet(10, 2, (32, 32, 16))
    x = torch.randn(4, 10)
    for mode in (pnet.train, pnet.eval):
        mode()
        assert torch.equal(pnet(x, stochastic=False), pnet(x, stochastic=False))
        assert not torch.equal(pnet(x, stochastic=True), pnet(x, stochastic=True))
    pnet.eval()
    with torch.inference_mode():
        a, b = pnet(x), pnet(x)  # the default is stochastic
        assert not torch.equal(a, b)
        det_eval = pnet(x, stochastic=False)
    pnet.train()
    with torch.no_grad():
        assert torch.equal(det_eval, pnet(x, stochastic=False))
    no_drop = Pnet(10, 2, (32, 32, 16), dropout=0.0)
    assert torch.equal(no_drop(x, stochastic=True), no_drop(x, stochastic=False))


# --------------------------------------------------------------------------- autoencoder


def test_penalty_uses_only_encoder_weights():
    torch.manual_seed(0)
    enet = Enet(40, (16, 8), 4)
    ae = ContractiveAE(enet, Decoder.mirror(enet), lam=0.01)
    expected = 0.01 * sum((m.weight**2).sum() for m in enet.net if isinstance(m, torch.nn.Linear))
    assert torch.allclose(ae.penalty(), expected)
    with torch.no_grad():
        for p in ae.decoder.parameters():
            p.mul_(3.0)
        for m in enet.linears():
            m.bias.add_(1.0)
        for m in enet.net:
            if isinstance(m, torch.nn.PReLU):
                m.weight.fill_(0.7)
    assert torch.allclose(ae.penalty(), expected)  # decoder, biases, PReLU: not penalised
    ae.zero_grad()
    ae.penalty().backward()
    assert all(p.grad is None for p in ae.decoder.parameters())
    assert all(m.weight.grad is not None and m.bias.grad is None for m in enet.linears())
    x = torch.randn(6, 40)
    total, recon, pen = ae.loss(x)
    assert torch.allclose(recon, F.mse_loss(ae(x), x))
    assert torch.allclose(total, recon + pen) and torch.allclose(pen, ae.penalty())


# --------------------------------------------------------------------------- normalizer


def test_normalizer():
    rigid = Normalizer.from_bounds([(-20, 20), (-20, 20), (-math.pi, math.pi)])
    assert rigid.to_list() == [20.0, 20.0, math.pi]
    x = np.array([[10.0, -20.0, math.pi / 2]])
    assert np.allclose(rigid.normalize(x), [[0.5, -1.0, 0.5]])
    assert np.allclose(rigid.denormalize(rigid.normalize(x)), x)
    t = torch.tensor(x, dtype=torch.float32)
    assert torch.allclose(rigid.normalize(t), torch.tensor([[0.5, -1.0, 0.5]]))
    assert rigid.normalize(t).dtype == torch.float32
    assert rigid.normalize(x.astype(np.float32)).dtype == np.float32
    # a flattened point-major cloud: the per-dimension scale is tiled
    pts = Normalizer([20.0, 10.0])
    cloud = np.array([20.0, 10.0, -20.0, 5.0], dtype=np.float32)
    assert np.allclose(pts.normalize(cloud), [1.0, 1.0, -1.0, 0.5])
    assert np.allclose(Normalizer(20.0).normalize(cloud), cloud / 20.0)
    assert Normalizer.points(3).to_list() == [20.0] * 3
    with pytest.raises(ValueError):
        rigid.normalize(np.zeros(4))
    with pytest.raises(ValueError):
        Normalizer([20.0, 0.0])


# --------------------------------------------------------------------------- numpy export


@pytest.mark.parametrize("size", ["paper", "small", "odd-slopes"])
def test_numpy_export_matches_torch_without_dropout(size):
    torch.manual_seed(1)
    if size == "paper":
        pnet, zdim, d = paper_s2d()[2], 28, 2
    else:
        pnet, zdim, d = Pnet(8 + 2 * 3, 3, (32, 16, 8)), 8, 3
    slopes = [-0.2, 1.3, 0.5] if size == "odd-slopes" else [0.1 + 0.05 * i for i in range(len(pnet.acts))]
    with torch.no_grad():  # non-trivial PReLU slopes (outside [0, 1]: the general branch)
        for act, a in zip(pnet.acts, slopes):
            act.weight.fill_(a)
    step = pnet_numpy(pnet)
    rng = np.random.default_rng(0)
    for _ in range(5):
        z, x, g = rng.normal(size=zdim), rng.uniform(-1, 1, d), rng.uniform(-1, 1, d)
        with torch.inference_mode():
            ref = pnet(torch.tensor(np.concatenate((z, x, g)), dtype=torch.float32), stochastic=False).numpy()
        out = step(z, x, g, None)
        assert out.shape == (d,)
        np.testing.assert_allclose(out, ref, rtol=1e-4, atol=1e-5)
    # a batch (2-D) and a shared z
    xs, gs = rng.uniform(-1, 1, (7, d)), rng.uniform(-1, 1, (7, d))
    z = rng.normal(size=zdim)
    with torch.inference_mode():
        inp = torch.tensor(np.concatenate((np.tile(z, (7, 1)), xs, gs), 1), dtype=torch.float32)
        ref = pnet(inp, stochastic=False).numpy()
    np.testing.assert_allclose(step(z, xs, gs), ref, rtol=1e-4, atol=1e-5)


def test_numpy_export_with_normalizer_takes_raw_states():
    torch.manual_seed(2)
    pnet = Pnet(4 + 6, 3, (16, 8))
    norm = Normalizer([20.0, 20.0, math.pi])
    step = pnet_numpy(pnet, norm)
    z = np.linspace(-1, 1, 4)
    x, g = np.array([5.0, -3.0, 1.0]), np.array([-12.0, 15.0, -2.5])
    with torch.inference_mode():
        ref = pnet.step(
            torch.tensor(z, dtype=torch.float32),
            torch.tensor(norm.normalize(x), dtype=torch.float32),
            torch.tensor(norm.normalize(g), dtype=torch.float32),
            stochastic=False,
        )
    np.testing.assert_allclose(step(z, x, g), norm.denormalize(ref.numpy()), rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(step(z, x[None], g[None])[0], step(z, x, g), rtol=1e-6)
    with pytest.raises(ValueError):
        step(z, x[:2], g[:2])


def test_numpy_export_dropout_is_seeded_and_has_torchs_mean():
    torch.manual_seed(3)
    pnet = Pnet(4 + 4, 2, (48, 32, 16))
    step = pnet_numpy(pnet)
    z, x, g = np.full(4, 0.3), np.array([0.2, -0.5]), np.array([-0.7, 0.4])
    a = step(z, x, g, np.random.default_rng(7))
    assert np.array_equal(a, step(z, x, g, np.random.default_rng(7)))
    n = 3000
    rng = np.random.default_rng(11)
    samples_np = np.array([step(z, x, g, rng) for _ in range(n)])
    torch.manual_seed(4)
    inp = torch.tensor(np.concatenate((z, x, g)), dtype=torch.float32).expand(n, -1)
    with torch.inference_mode():
        samples_t = pnet(inp, stochastic=True).numpy()
    assert samples_np.std(0).min() > 1e-3  # dropout really is on
    se = np.sqrt(samples_np.var(0) / n + samples_t.var(0) / n)
    assert np.all(np.abs(samples_np.mean(0) - samples_t.mean(0)) < 5 * se)
    ratio = samples_np.std(0) / samples_t.std(0)
    assert np.all((ratio > 0.85) & (ratio < 1.18))
    # a batch draws a mask per row
    rows = step(z, np.tile(x, (5, 1)), np.tile(g, (5, 1)), np.random.default_rng(0))
    assert len({tuple(r) for r in rows.round(6)}) > 1


def test_numpy_encoder_matches_torch():
    torch.manual_seed(5)
    enet = Enet(2800, latent=28)
    norm = Normalizer(20.0)
    cloud = np.random.default_rng(0).uniform(-20, 20, 2800).astype(np.float32)
    with torch.inference_mode():
        ref = enet(torch.from_numpy(cloud / 20.0)).numpy()
    np.testing.assert_allclose(enet_numpy(enet, norm)(cloud), ref, rtol=1e-4, atol=1e-5)
    points = cloud.reshape(1400, 2)  # what the planner's cloud(workspace) gives
    np.testing.assert_allclose(enet_numpy(enet, norm)(points), ref, rtol=1e-4, atol=1e-5)
    with pytest.raises(ValueError):
        enet_numpy(enet, norm)(points[:-1])


# --------------------------------------------------------------------------- data modules


def test_split_is_deterministic_disjoint_and_grouped():
    tr, va = split_indices(100, 0.2, seed=3)
    tr2, va2 = split_indices(100, 0.2, seed=3)
    assert np.array_equal(tr, tr2) and np.array_equal(va, va2)
    assert len(va) == 20 and np.array_equal(np.sort(np.concatenate((tr, va))), np.arange(100))
    assert not np.array_equal(va, split_indices(100, 0.2, seed=4)[1])
    groups = np.repeat(np.arange(10), 5)
    tr, va = split_indices(50, 0.3, seed=0, groups=groups)
    assert not set(groups[tr]) & set(groups[va]) and len(set(groups[va])) == 3
    assert len(split_indices(2, 0.01, 0)[1]) == 1 and len(split_indices(5, 0.0, 0)[1]) == 0


def test_waypoint_pairs_both_directions():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    p = waypoint_pairs([path, path[:1]], [4, 5])
    assert len(p.x_t) == 4 and set(p.ws_index) == {4} and set(p.path_id) == {0}
    np.testing.assert_array_equal(p.x_t[:2], path[:2])
    np.testing.assert_array_equal(p.x_next[:2], path[1:])
    np.testing.assert_array_equal(p.x_goal[:2], [path[-1]] * 2)
    np.testing.assert_array_equal(p.x_t[2:], path[::-1][:2])
    np.testing.assert_array_equal(p.x_goal[2:], [path[0]] * 2)
    assert len(waypoint_pairs([path], [0], bidirectional=False).x_t) == 2


def test_waypoint_pairs_across_pi_train_on_wrapped_inputs():
    """A rigid path that crosses theta = +-pi (and one stored unwrapped): Pnet's inputs are
    wrapped, as the planner feeds them; each target is the next state as the motion reaches
    it from the input (3.0 -> 3.0 + 0.283, not -3.0), within a step of [-pi, pi)."""
    from mpnet.envs import get_spec

    space = get_spec("rigid").space
    wrapped = np.array([[0.0, 0.0, 3.0], [1.0, 0.0, -3.0], [2.0, 0.0, -2.5]])
    unwrapped = np.array([[0.0, 0.0, 3.0], [1.0, 0.0, 2 * np.pi - 3.0], [2.0, 0.0, 2 * np.pi - 2.5]])
    for path in (wrapped, unwrapped):
        p = waypoint_pairs([path], [0], space=space)
        for x in (p.x_t, p.x_goal):
            assert np.all((x[:, 2] >= -np.pi) & (x[:, 2] < np.pi))
        np.testing.assert_allclose(p.x_next[0], [1.0, 0.0, 2 * np.pi - 3.0])
        np.testing.assert_allclose(p.x_t[1], [1.0, 0.0, -3.0])
        np.testing.assert_allclose(
            np.abs(space.difference(p.x_t, p.x_next)[:, 2]), np.abs(p.x_next[:, 2] - p.x_t[:, 2])
        )
        np.testing.assert_allclose(space.wrap(p.x_next), space.wrap(np.concatenate([path[1:], path[-2::-1]])))


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.lists(st.floats(-3, 3), min_size=7, max_size=7), min_size=2, max_size=6),
    st.floats(0.05, 2.0),
)
def test_resampled_paths_keep_their_states_and_take_steps_of_at_most_the_step(states, step):
    """mpnet_nr_dense's training paths: the expert's states all kept, in order, every step at
    most `waypoint_step` (the space's distance), the segments' lengths unchanged."""
    from mpnet.envs import get_spec

    space = get_spec("panda_mbm").space
    path = np.array(states)
    out = resample_path(path, step, space)
    steps = np.linalg.norm(np.diff(out, axis=0), axis=1)
    assert np.all(steps <= step + 1e-9)
    assert np.isclose(steps.sum(), np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
    at = 0  # each expert state found in order, after the previous one
    for q in path[1:]:
        at += 1 + int(np.flatnonzero(np.all(np.isclose(out[at + 1 :], q), axis=1))[0])
    assert at == len(out) - 1 and np.array_equal(out[0], path[0])
    pairs = waypoint_pairs([path], [0], space=space, waypoint_step=step)
    assert len(pairs.x_t) == 2 * (len(out) - 1)


def test_resample_path_refuses_a_step_that_is_not_positive():
    with pytest.raises(ValueError, match="waypoint_step"):
        resample_path(np.zeros((2, 2)), 0.0)


def _pair_data(n=2000, n_ws=12, cloud_dim=120, seed=0):
    rng = np.random.default_rng(seed)
    clouds = rng.uniform(-20, 20, (n_ws, cloud_dim)).astype(np.float32)
    ws = rng.integers(0, n_ws, n)
    x_t = rng.uniform(-20, 20, (n, 2))
    x_goal = rng.uniform(-20, 20, (n, 2))
    shift = clouds[ws, :2] * 0.1  # depends on the workspace a little
    x_next = x_t + 0.3 * (x_goal - x_t) + shift
    return clouds, ws, x_t, x_goal, x_next


def test_mpnet_datamodule_batches():
    clouds, ws, x_t, x_goal, x_next = _pair_data(n=300)
    dm = MPNetDataModule(clouds, ws, x_t, x_goal, x_next, batch_size=64, val_fraction=0.25, seed=1)
    assert (dm.state_dim, dm.cloud_dim) == (2, 120)
    assert len(dm.val_indices) == 75
    dm.setup("fit")
    seen = []
    for b in dm.val_dataloader():
        assert b["clouds"].dtype == torch.float32 and b["x_t"].dtype == torch.float32
        assert len(b["clouds"]) == len(torch.unique(b["ws"]))
        seen.append(b)
    rows = dm.val_indices[:64]  # validation is not shuffled
    np.testing.assert_allclose(seen[0]["clouds"][seen[0]["ws"]].numpy(), clouds[ws[rows]])
    np.testing.assert_allclose(seen[0]["x_next"].numpy(), x_next[rows], rtol=1e-6)
    assert sum(len(b["x_t"]) for b in dm.train_dataloader()) == 225
    with pytest.raises(ValueError):
        MPNetDataModule(clouds, ws + 100, x_t, x_goal, x_next, 8, 0.1, 0)
    with pytest.raises(ValueError):
        MPNetDataModule(clouds, ws, x_t, x_goal[:-1], x_next, 8, 0.1, 0)
    cdm = CloudDataModule(clouds, batch_size=5, val_fraction=0.25, seed=0)
    cdm.setup("fit")
    assert [tuple(b.shape) for b in cdm.val_dataloader()] == [(3, 120)]


# --------------------------------------------------------------------------- Lightning


def _trainer(tmp_path):
    return L.Trainer(
        max_epochs=2,
        accelerator="cpu",
        logger=False,
        enable_checkpointing=True,
        default_root_dir=tmp_path,
        enable_progress_bar=False,
        enable_model_summary=False,
    )


def _ae_loss(module: EnetModule, clouds: np.ndarray) -> float:
    with torch.no_grad():
        return float(module.losses(torch.from_numpy(clouds))[0])


def _pnet_loss(module: PnetModule, data) -> float:
    clouds, ws, x_t, x_goal, x_next = (torch.as_tensor(a) for a in data)
    batch = {"clouds": clouds.float(), "ws": ws, "x_t": x_t.float(), "x_goal": x_goal.float(), "x_next": x_next.float()}
    with torch.no_grad():
        return float(module.batch_loss(batch, stochastic=False)[0])


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_train_enet_then_pnet_and_reload(tmp_path):
    L.seed_everything(0)
    data = _pair_data()
    clouds = data[0]
    # a low-rank family of clouds, so the autoencoder has something to learn in 2 epochs
    rng = np.random.default_rng(0)
    ae_clouds = (rng.normal(size=(512, 3)) @ rng.normal(size=(3, 120)) * 4).astype(np.float32)
    enet = Enet(120, (32, 16), 6)
    emod = EnetModule(ContractiveAE(enet, Decoder.mirror(enet)), lr=1e-2, lam=1e-4, optimizer="adam", cloud_scale=20.0)
    before = _ae_loss(emod, ae_clouds)
    trainer = _trainer(tmp_path / "enet")
    trainer.fit(emod, CloudDataModule(ae_clouds, batch_size=16, val_fraction=0.25, seed=0))
    assert {"train_loss", "val_loss", "train_penalty"} <= set(trainer.callback_metrics)
    assert _ae_loss(emod, ae_clouds) < 0.7 * before
    ckpt = trainer.checkpoint_callback.best_model_path
    again = EnetModule.load_from_checkpoint(ckpt)
    assert again.hparams == emod.hparams and again.hparams["lam"] == 1e-4
    for k, v in emod.state_dict().items():
        assert torch.equal(v, again.state_dict()[k])
    ae, cloud_norm = load_enet_checkpoint(ckpt)
    assert cloud_norm.to_list() == [20.0]
    with torch.no_grad():
        assert torch.equal(ae.encoder(torch.ones(1, 120)), emod.ae.encoder(torch.ones(1, 120)))

    # Pnet on the trained (frozen) encoder
    enc_before = {k: v.clone() for k, v in emod.encoder.state_dict().items()}
    pmod = PnetModule(Pnet(6 + 4, 2, (64, 32, 16)), emod.encoder, lr=3e-3, optimizer="adam", **SCALES_2D)
    before = _pnet_loss(pmod, data)
    trainer = _trainer(tmp_path / "pnet")
    trainer.fit(pmod, MPNetDataModule(*data, batch_size=50, val_fraction=0.1, seed=0))
    assert {"train_loss", "val_loss"} <= set(trainer.callback_metrics)
    assert _pnet_loss(pmod, data) < 0.5 * before
    for k, v in pmod.encoder.state_dict().items():
        assert torch.equal(v, enc_before[k])  # frozen
    ckpt = trainer.checkpoint_callback.best_model_path
    again = PnetModule.load_from_checkpoint(ckpt)
    assert again.hparams == pmod.hparams and again.freeze_encoder
    for k, v in pmod.state_dict().items():
        assert torch.equal(v, again.state_dict()[k])
    cloud = torch.from_numpy(clouds[3])
    x, g = torch.tensor([[1.0, 2.0]]), torch.tensor([[-5.0, 7.0]])
    with torch.inference_mode():
        ref = pmod(cloud, x, g, stochastic=False)
        assert torch.equal(again(cloud, x, g, stochastic=False), ref)
    # without Lightning: the planner's reader and its numpy versions agree
    nets = load_pnet_checkpoint(ckpt)
    assert nets.state_norm.to_list() == [20.0, 20.0] and nets.cloud_norm.to_list() == [20.0]
    np_enet, np_pnet = nets.to_numpy()
    z = np_enet(clouds[3].reshape(60, 2))
    np.testing.assert_allclose(z, nets.encode(clouds[3].reshape(60, 2)).numpy(), rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(np_pnet(z, x[0].numpy(), g[0].numpy()), ref[0].numpy(), rtol=1e-4, atol=1e-4)


def test_precomputed_codes_give_the_same_loss_as_clouds():
    """Training on a frozen encoder's codes, computed once, is training on the clouds."""
    torch.manual_seed(0)
    clouds, ws, x_t, x_goal, x_next = _pair_data(n=50)
    mod = PnetModule(Pnet(4 + 4, 2, (16, 8)), Enet(120, (16,), 4), **SCALES_2D)
    with torch.no_grad():
        codes = mod.encode(torch.from_numpy(clouds).float()).numpy()
    by_cloud = MPNetDataModule(clouds, ws, x_t, x_goal, x_next, batch_size=50, val_fraction=0.2, seed=0)
    by_code = MPNetDataModule(codes, ws, x_t, x_goal, x_next, batch_size=50, val_fraction=0.2, seed=0, features="codes")
    by_cloud.setup("fit")
    by_code.setup("fit")
    (a,), (b,) = list(by_cloud.val_dataloader()), list(by_code.val_dataloader())
    assert "codes" in b and "clouds" not in b
    with torch.no_grad():
        la, lb = mod.batch_loss(a, stochastic=False)[0], mod.batch_loss(b, stochastic=False)[0]
    assert torch.allclose(la, lb, rtol=1e-5, atol=1e-7)
    end_to_end = PnetModule(Pnet(4 + 4, 2, (16, 8)), Enet(120, (16,), 4), freeze_encoder=False, **SCALES_2D)
    with pytest.raises(ValueError, match="frozen"):
        end_to_end.batch_loss(b, stochastic=False)
    with pytest.raises(ValueError):
        MPNetDataModule(codes, ws, x_t, x_goal, x_next, 8, 0.1, 0, features="pixels")


def test_pnet_module_end_to_end_and_checks():
    torch.manual_seed(0)
    enet = Enet(120, (16,), 4)
    mod = PnetModule(
        Pnet(4 + 6, 3, (16, 8)), enet, freeze_encoder=False, state_scale=[20.0, 20.0, math.pi], cloud_scale=20.0
    )
    opt = mod.configure_optimizers()
    n_opt = sum(p.numel() for grp in opt.param_groups for p in grp["params"])
    assert n_opt == sum(p.numel() for p in mod.parameters())
    assert isinstance(opt, torch.optim.Adagrad)
    batch = (torch.randn(5, 120), torch.randn(5, 3), torch.randn(5, 3), torch.randn(5, 3))
    mod.batch_loss(batch, stochastic=True)[0].backward()
    assert all(p.grad is not None for p in enet.parameters())
    frozen = PnetModule(Pnet(4 + 6, 3, (16, 8)), Enet(120, (16,), 4), state_scale=[20, 20, math.pi], cloud_scale=20.0)
    n_opt = sum(p.numel() for grp in frozen.configure_optimizers().param_groups for p in grp["params"])
    assert n_opt == sum(p.numel() for p in frozen.pnet.parameters())
    with pytest.raises(ValueError):
        PnetModule(Pnet(11, 3, (16,)), Enet(120, (16,), 4), **SCALES_2D)
    with pytest.raises(ValueError):
        PnetModule(Pnet(10, 3, (16,)), Enet(120, (16,), 4), optimizer="sgd", **SCALES_2D)


@pytest.mark.slow
def test_importing_the_package_does_not_import_lightning():
    code = (
        "import sys, mpnet.models, mpnet.models.networks, mpnet.models.checkpoint; "
        "assert 'lightning' not in sys.modules and 'pytorch_lightning' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


@pytest.mark.parametrize("p", [0.5, 0.3])
def test_folded_dropout_scale_is_bit_identical(p):
    """With p = 0.5 the export folds dropout's x2 into the next layer's weights (exact in
    floating point); a step must equal, bit for bit, the unfolded step with the same draws.
    With p = 0.3 (1/0.7 is not a power of two) nothing is folded."""
    torch.manual_seed(0)
    pnet = Pnet(12, 2, [64, 32, 16], dropout=p).eval()
    folded, plain = pnet_numpy(pnet), pnet_numpy(pnet)
    assert folded._fold == (p == 0.5)
    plain._fold, plain._dropout_weights = False, plain.weights
    z, rng_a, rng_b = np.linspace(-1, 1, 8).astype(np.float32), np.random.default_rng(7), np.random.default_rng(7)
    for x in np.random.default_rng(1).uniform(-3, 3, size=(50, 2)):
        a, b = folded.step(z, x, -x, rng_a), plain.step(z, x, -x, rng_b)
        assert np.array_equal(a, b)


def test_input_noise_moves_only_the_training_states():
    """The DART-style recipe option: training batches see x_t moved by N(0, noise^2) (so the loss
    changes), validation and the zero default see the states as given; it is saved with the
    module and a negative noise is refused."""
    torch.manual_seed(0)
    batch = (torch.randn(64, 120), torch.randn(64, 2), torch.randn(64, 2), torch.randn(64, 2))
    noisy = PnetModule(Pnet(4 + 4, 2, (16, 8), dropout=0.0), Enet(120, (16,), 4), input_noise=3.0, **SCALES_2D)
    plain = PnetModule(Pnet(4 + 4, 2, (16, 8), dropout=0.0), Enet(120, (16,), 4), **SCALES_2D)
    plain.load_state_dict(noisy.state_dict())
    with torch.no_grad():
        clean = plain.batch_loss(batch, stochastic=False)[0]
        assert torch.equal(noisy.batch_loss(batch, stochastic=False)[0], clean)  # validation: no noise
        assert not torch.equal(noisy.batch_loss(batch, stochastic=False, noise=noisy.input_noise)[0], clean)
    assert noisy.hparams["input_noise"] == 3.0 and "input_noise" not in plain.hparams
    with pytest.raises(ValueError, match="input_noise"):
        PnetModule(Pnet(4 + 4, 2, (16, 8)), Enet(120, (16,), 4), input_noise=-1.0, **SCALES_2D)


def test_min_waypoints_resamples_each_path_to_at_least_that_many_states():
    """The paper's Baxter paths were MoveIt's interpolated trajectories (at least 10 states):
    every path gets at least min_waypoints states (its own kept, in order), and
    waypoint_step still bounds the spacing where it is shorter."""
    rng = np.random.default_rng(0)
    paths = [np.cumsum(rng.uniform(-1, 1, (n, 3)), axis=0) for n in (2, 3, 5, 14)]
    for n in (2, 10, 25):
        pairs = waypoint_pairs(paths, list(range(4)), bidirectional=False, min_waypoints=n)
        counts = np.bincount(pairs.path_id, minlength=4) + 1  # states = forward pairs + 1
        assert np.all(counts >= np.array([max(n, len(p)) if n > 2 else len(p) for p in paths]))
        for i, p in enumerate(paths):
            states = np.vstack([pairs.x_t[pairs.path_id == i], pairs.x_next[pairs.path_id == i][-1:]])
            assert all(any(np.allclose(q, s) for s in states) for q in p)  # the path's own states stay
    fine = waypoint_pairs(paths, list(range(4)), bidirectional=False, min_waypoints=3, waypoint_step=0.1)
    assert np.max(np.linalg.norm(fine.x_next - fine.x_t, axis=1)) <= 0.1 + 1e-9
    with pytest.raises(ValueError, match="min_waypoints"):
        waypoint_pairs(paths, list(range(4)), min_waypoints=1)
