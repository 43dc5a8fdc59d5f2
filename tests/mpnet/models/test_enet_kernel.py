"""The compiled encoding (mpnet.models.enet_kernel) against NumpyEnet's, and the compiled point
cloud (mpnet.envs.scenes.clouds.point_cloud) against numpy's formula: the same bits."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet.envs.scenes.clouds import cloud_rng, point_cloud
from mpnet.envs.workspace import Workspace
from mpnet.models import load_pnet_checkpoint
from mpnet.models.enet_kernel import EnetKernel
from mpnet.models.networks import Enet, Normalizer, NumpyEnet
from mpnet.models.pretrained import SHIPPED, write_checkpoint


def _same_codes(enet: NumpyEnet, rng: np.random.Generator, n: int = 20) -> None:
    kernel = EnetKernel(enet)
    for _ in range(n):
        cloud = (rng.standard_normal(enet.in_dim) * 10).astype(np.float32)
        want = enet.encode(cloud)
        assert want.dtype == np.float32 and np.array_equal(want, kernel.encode(cloud))
    points = cloud.reshape(-1, 2) if enet.in_dim % 2 == 0 and enet.in_dim > 2 else cloud[:, None]
    assert np.array_equal(enet.encode(points), kernel.encode(points))  # a cloud given as points


@settings(deadline=None, max_examples=25)
@given(
    seed=st.integers(0, 2**31 - 1),
    in_dim=st.integers(2, 300),
    hidden=st.lists(st.integers(2, 40), min_size=0, max_size=3),
    latent=st.integers(2, 30),
    alpha=st.sampled_from([0.25, -0.3, 1.5]),
    scaled=st.booleans(),
)
def test_the_compiled_encoding_is_numpys_bit_for_bit(seed, in_dim, hidden, latent, alpha, scaled):
    torch.manual_seed(seed)
    net = Enet(in_dim, hidden, latent).eval()
    for m in net.net:
        if isinstance(m, torch.nn.PReLU):
            torch.nn.init.constant_(m.weight, alpha)
    normalizer = Normalizer(np.random.default_rng(seed).uniform(0.5, 20.0, 1 if in_dim % 2 else 2)) if scaled else None
    _same_codes(NumpyEnet(net, normalizer), np.random.default_rng(seed))


@pytest.mark.parametrize("folder", sorted(SHIPPED.iterdir()), ids=lambda p: p.name)
def test_the_shipped_networks_encode_the_same(folder, tmp_path):
    write_checkpoint(folder, tmp_path / "pnet.ckpt")
    encode, _ = load_pnet_checkpoint(tmp_path / "pnet.ckpt").to_numpy()
    _same_codes(encode, np.random.default_rng(0), n=5)


def test_a_one_wide_layer_or_a_batch_is_refused():
    with pytest.raises(ValueError, match="2 wide"):
        EnetKernel(NumpyEnet(Enet(10, (4,), 1)))
    with pytest.raises(ValueError, match="one cloud"):
        EnetKernel(NumpyEnet(Enet(10, (4,), 3))).encode(np.zeros((2, 10), np.float32))


def _numpy_point_cloud(ws, total, rng):
    """point_cloud as numpy drew it before it was compiled."""
    n = len(ws.centers)
    counts = np.full(n, total // n)
    counts[: total % n] += 1
    idx = np.repeat(np.arange(n), counts)
    return ws.lo[idx] + rng.uniform(size=(total, ws.dim)) * (ws.hi - ws.lo)[idx]


@settings(deadline=None, max_examples=50)
@given(
    seed=st.integers(0, 2**31 - 1),
    dim=st.sampled_from([2, 3]),
    blocks=st.integers(1, 12),
    total=st.integers(1, 3000),
)
def test_the_compiled_point_cloud_draws_as_numpy(seed, dim, blocks, total):
    rng = np.random.default_rng(seed)
    centers = rng.uniform(-20, 20, (blocks, dim))
    half = rng.uniform(0.1, 5, (blocks, dim))
    ws = Workspace("7", "seen", centers, 2 * half)
    a, b = np.random.default_rng(seed), np.random.default_rng(seed)
    assert np.array_equal(point_cloud(ws, total, a), _numpy_point_cloud(ws, total, b))
    assert a.random() == b.random()  # the same draws taken
    listed_otherwise = Workspace("other", "seen", centers[::-1], 2 * half[::-1])  # the same scene
    assert np.array_equal(
        point_cloud(ws, total, cloud_rng(0, ws)), point_cloud(ws, total, cloud_rng(0, listed_otherwise))
    )
