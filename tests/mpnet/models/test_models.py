"""MPNet's networks and their numpy export: shapes, dropout, the autoencoder's penalty, the
normalizer, the export against torch."""

import math

import numpy as np
import pytest
import torch
import torch.nn.functional as F

import mpnet.models.networks as networks
from mpnet.models import PNET_HIDDEN, ContractiveAE, Decoder, Enet, Normalizer, Pnet, enet_numpy, paper_s2d, pnet_numpy


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
