"""The torch-free checkpoint reader (mpnet.models.torch_zip) against torch.load, and the
planner's networks read through it (load_pnet_numpy) against load_pnet_checkpoint."""

from __future__ import annotations

import pathlib
import subprocess
import sys

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet.models import Enet, Pnet
from mpnet.models.checkpoint import CheckpointError, load_pnet_checkpoint, load_pnet_numpy
from mpnet.models.torch_zip import load


def _same(a, b) -> None:
    """a (torch.load's) and b (ours) hold the same values, tensors as arrays bit for bit."""
    if isinstance(a, torch.Tensor):
        assert isinstance(b, np.ndarray) and b.dtype == a.numpy().dtype and b.shape == tuple(a.shape)
        assert b.tobytes() == a.contiguous().numpy().tobytes()
    elif isinstance(a, dict):
        assert type(b) is type(a) and list(a) == list(b)
        for k in a:
            _same(a[k], b[k])
    elif isinstance(a, (list, tuple)):
        assert type(b) is type(a) and len(a) == len(b)
        for x, y in zip(a, b):
            _same(x, y)
    else:
        assert a == b


def test_tensors_of_every_kind_read_as_torch_reads_them(tmp_path):
    base = torch.arange(24, dtype=torch.float32).reshape(4, 6)
    obj = {
        "state_dict": {
            "w": torch.randn(5, 3),
            "transposed": base.t(),  # a strided view: the whole storage is saved
            "slice": base[1:, 2:5],
            "shared": base,  # the same storage again
            "scalar": torch.tensor(2.5),
            "double": torch.randn(3, dtype=torch.float64),
            "long": torch.arange(4),
            "int": torch.arange(3, dtype=torch.int32),
            "bool": torch.tensor([True, False, True]),
            "half": torch.randn(4).half(),
            "empty": torch.zeros(0, 3),
        },
        "hyper_parameters": {"pnet": {"hidden": [8, 4], "dropout": 0.5}, "scale": [20.0, 3.14], "name": "x"},
        "nested": [1, (2, 3.0), None, True],
    }
    f = tmp_path / "a.ckpt"
    torch.save(obj, f)
    _same(torch.load(f, weights_only=True), load(f))


@settings(max_examples=25, deadline=None)
@given(
    hidden=st.lists(st.integers(1, 9), min_size=1, max_size=4),
    dims=st.tuples(st.integers(1, 7), st.integers(1, 3), st.integers(1, 6)),
    dropout=st.sampled_from([0.0, 0.25, 0.5]),
)
def test_the_planners_networks_are_the_checkpoints_bit_for_bit(
    tmp_path_factory, write_pnet_checkpoint, hidden, dims, dropout
):
    state_dim, wdim, latent = dims
    enet = Enet(10 * wdim, hidden, latent)
    pnet = Pnet(latent + 2 * state_dim, state_dim, hidden, dropout)
    for m in (*pnet.acts, *(m for m in enet.net if isinstance(m, torch.nn.PReLU))):
        torch.nn.init.uniform_(m.weight, 0.05, 0.6)  # PReLUs that differ from their default
    f = write_pnet_checkpoint(tmp_path_factory.mktemp("ckpt") / "pnet.ckpt", enet, pnet, [3.0] * state_dim, [20.0])
    (e1, p1), (e2, p2) = load_pnet_numpy(f), load_pnet_checkpoint(f).to_numpy()
    for a, b in zip(p1.weights + p1.biases + e1.weights + e1.biases, p2.weights + p2.biases + e2.weights + e2.biases):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    assert (p1.alphas, e1.alphas, p1.p, p1.n_dropout) == (p2.alphas, e2.alphas, p2.p, p2.n_dropout)
    cloud = np.random.default_rng(1).uniform(-20, 20, 10 * wdim).astype(np.float32)
    z = e1(cloud)
    assert z.tobytes() == e2(cloud).tobytes()
    x, goal = np.full(state_dim, 0.5), np.full(state_dim, -1.0)
    got, want = p1(z, x, goal, np.random.default_rng(7)), p2(z, x, goal, np.random.default_rng(7))
    assert got.tobytes() == want.tobytes()


def test_other_globals_are_refused_in_one_line(tmp_path):
    f = tmp_path / "pnet.ckpt"
    torch.save({"hyper_parameters": {"where": pathlib.PurePosixPath("/x")}, "state_dict": {}}, f)
    with pytest.raises(CheckpointError, match=r"pnet\.ckpt: unreadable checkpoint \(UnpicklingError: global pathlib"):
        load_pnet_numpy(f)


@pytest.mark.parametrize("damage", ["empty", "cut", "text", "not_pnet"])
def test_a_damaged_checkpoint_is_one_line_naming_the_file(tmp_path, damage):
    f = tmp_path / "pnet.ckpt"
    torch.save({"hyper_parameters": {"pnet": {}}, "state_dict": {"pnet.w": torch.ones(1000)}}, f)
    raw = f.read_bytes()
    f.write_bytes({"empty": b"", "cut": raw[: len(raw) // 2], "text": b"hello", "not_pnet": raw}[damage])
    with pytest.raises(CheckpointError) as e:
        load_pnet_numpy(f)
    assert str(f) in str(e.value) and "\n" not in str(e.value)


@pytest.mark.slow  # a subprocess
def test_planning_reads_its_networks_without_importing_torch(tmp_path, write_pnet_checkpoint):
    """What a planning run imports to build MPNet from a checkpoint: no torch (~1.5 s)."""
    enet, pnet = Enet(20, (8,), 4), Pnet(4 + 4, 2, (8, 4))
    write_pnet_checkpoint(tmp_path / "pnet.ckpt", enet, pnet, [20.0, 20.0], [20.0])
    code = (
        "import sys, numpy as np\n"
        "from mpnet.envs.specs import get_spec\n"
        "from mpnet.planners.mpnet import from_checkpoint\n"
        f"p = from_checkpoint({str(tmp_path)!r}, get_spec('s2d'), 0, lambda ws: np.zeros((10, 2)), name='mpnet_nr')\n"
        "assert 'torch' not in sys.modules, 'torch imported'\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
