"""The voxel Enet (planner.networks.voxels, issue 42): the occupancy's known cells, the same grid
in numpy, the compiled kernel and torch, an encoding that ignores the points' order, a
checkpoint that rebuilds it, and the config's refusals."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet import models  # its LightningModules load on first use, not as pytest collects
from mpnet.models.checkpoint import load_pnet_checkpoint, load_pnet_numpy
from mpnet.models.enet_kernel import EnetKernel
from mpnet.models.networks import ContractiveAE, Decoder, Enet, Normalizer, NumpyEnet, Pnet
from mpnet.models.voxels import grid_cells, occupancy, occupancy_into


def test_known_cells():
    """floor((p + 1) * cells / 2) per axis, row-major; outside [-1, 1) and NaN dropped."""
    cells = (2, 4)
    pts = np.array(
        [
            [-1.0, -1.0],  # first cell
            [0.99, 0.99],  # last cell
            [0.0, -0.5],  # (1, 1): 0 is the upper half's first
            [1.0, 0.0],  # x = 1 is outside [-1, 1)
            [-1.01, 0.0],  # outside
            [np.nan, 0.0],  # dropped
        ],
        np.float32,
    )
    occ = occupancy(pts.reshape(-1), cells)
    assert occ.dtype == np.float32 and occ.shape == (8,)
    assert np.flatnonzero(occ).tolist() == [0, 5, 7]
    out = np.full(8, 7.0, np.float32)
    occupancy_into(pts.reshape(-1), np.array(cells, np.int64), out)
    assert np.array_equal(out, occ)


def test_a_batch_and_a_cloud_of_no_points_inside():
    cloud = np.full((3, 10 * 3), 5.0, np.float32)
    cloud[1, :3] = 0.0
    occ = occupancy(cloud, (3, 3, 3))
    assert occ.shape == (3, 27) and occ.sum() == 1 and occ[1, 13] == 1


@settings(deadline=None, max_examples=30)
@given(
    seed=st.integers(0, 2**31 - 1),
    cells=st.lists(st.integers(1, 7), min_size=1, max_size=3),
    n=st.integers(1, 60),
    spread=st.sampled_from([0.5, 1.0, 1.5]),
)
def test_numpy_compiled_and_torch_grids_agree_and_ignore_the_order(seed, cells, n, spread):
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-spread, spread, (n, len(cells))).astype(np.float32)
    edge = rng.random(n) < 0.3
    pts[edge] = np.round(pts[edge] * 4) / 4  # on cell edges (cells of 2, 4: a quarter is an edge)
    flat = pts.reshape(-1)
    want = occupancy(flat, cells)
    got = np.empty_like(want)
    occupancy_into(flat, np.array(cells, np.int64), got)
    enet = Enet(flat.size, (4,), 2, voxels=cells)
    assert np.array_equal(want, got)
    assert np.array_equal(want, enet.occupancy(torch.from_numpy(flat)).numpy())
    assert np.array_equal(want, occupancy(pts[rng.permutation(n)].reshape(-1), cells))
    keys = np.floor((pts.astype(np.float64) + 1) * np.array(cells) / 2)
    assert want.sum() == len({tuple(c) for c in keys if all(0 <= k < m for k, m in zip(c, cells))})


def _voxel_nets(seed: int = 0):
    torch.manual_seed(seed)
    enet = Enet(60 * 3, (16, 8), 6, voxels=(4, 4, 4)).eval()
    pnet = Pnet(6 + 2 * 7, 7, (32, 16), dropout=0.1).eval()
    return enet, pnet


def test_the_encoding_ignores_the_points_order_in_numpy_compiled_and_torch():
    enet, _ = _voxel_nets()
    norm = Normalizer([1.5, 1.5, 1.5])
    rng = np.random.default_rng(1)
    cloud = rng.uniform(-1.6, 1.6, (60, 3)).astype(np.float32)
    shuffled = cloud[rng.permutation(60)]
    numpy_enet = NumpyEnet(enet, norm)
    kernel = EnetKernel(numpy_enet)
    z = numpy_enet.encode(cloud)
    assert np.array_equal(z, numpy_enet.encode(shuffled))
    assert np.array_equal(z, kernel.encode(cloud)) and np.array_equal(z, kernel.encode(shuffled))
    with torch.no_grad():
        zt = enet(norm.normalize(torch.from_numpy(shuffled.reshape(-1))))
    assert np.allclose(z, zt.numpy(), atol=1e-5)


def test_a_checkpoint_rebuilds_the_voxel_encoder(tmp_path):
    """Saved by the PnetModule (the config keeps `voxels`), read back by torch and by the
    torch-free loader a planning run uses: the same codes."""
    import lightning as L

    enet, pnet = _voxel_nets(3)
    module = models.PnetModule(pnet, enet, freeze_encoder=False, state_scale=[3.0] * 7, cloud_scale=[1.0, 1.0, 1.0])
    trainer = L.Trainer(max_epochs=0, logger=False, enable_checkpointing=False, enable_progress_bar=False)
    trainer.strategy.connect(module)
    path = tmp_path / "pnet.ckpt"
    trainer.save_checkpoint(path)
    cloud = np.random.default_rng(4).uniform(-1.2, 1.2, 180).astype(np.float32)
    nets = load_pnet_checkpoint(path)
    assert nets.encoder.voxels == (4, 4, 4)
    numpy_enet, _ = load_pnet_numpy(path)
    assert numpy_enet.voxels == (4, 4, 4)
    assert np.allclose(numpy_enet.encode(cloud), nets.encode(cloud).numpy(), atol=1e-5)
    assert np.array_equal(numpy_enet.encode(cloud), NumpyEnet(enet, Normalizer([1.0] * 3)).encode(cloud))


def test_refusals():
    with pytest.raises(ValueError, match="cells per axis"):
        grid_cells([4, 0])
    with pytest.raises(ValueError, match="3-D points"):
        Enet(10, (4,), 2, voxels=(2, 2, 2))
    enet = Enet(12, (4,), 2, voxels=(2, 2, 2))
    with pytest.raises(ValueError, match="end to end"):
        Decoder.mirror(enet)
    with pytest.raises(ValueError, match="end to end"):
        ContractiveAE(enet, Decoder(12, (4,), 2))


def test_the_paper_encoder_keeps_its_config():
    """No `voxels` key unless asked: the shipped networks' configs and keys stay."""
    assert Enet(12, (4,), 2).config() == {"in_dim": 12, "hidden": [4], "latent": 2}


def test_a_batch_of_grids_gives_the_loss_of_its_clouds():
    """Training reads each workspace's grid computed once (models.PnetModule.grids, the planner's
    numpy occupancy); the same batch as clouds, voxelised by torch, gives the same loss and
    the same encoder gradient."""
    from mpnet.models.datamodule import MPNetDataModule

    enet, pnet = _voxel_nets(5)
    module = models.PnetModule(pnet, enet, freeze_encoder=False, state_scale=[3.0] * 7, cloud_scale=[1.5, 1.5, 1.5])
    rng = np.random.default_rng(6)
    clouds = rng.uniform(-1.8, 1.8, (4, 180)).astype(np.float32)
    ws = np.repeat(np.arange(4), 5)
    xs = [rng.uniform(-2, 2, (20, 7)).astype(np.float32) for _ in range(3)]
    grads = []
    for feats, kind in ((clouds, "clouds"), (module.grids(clouds), "grids")):
        dm = MPNetDataModule(feats, ws, *xs, batch_size=20, val_fraction=0.0, features=kind)
        dm.setup()
        batch = dm.train_set.__getitems__(list(range(20)))
        module.zero_grad()
        loss, _ = module.batch_loss(batch, stochastic=False)
        loss.backward()
        grads.append((loss.item(), module.encoder.linears()[0].weight.grad.clone()))
    assert grads[0][0] == grads[1][0] and torch.equal(grads[0][1], grads[1][1])
