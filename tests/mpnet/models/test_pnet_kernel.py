"""The compiled Pnet step (mpnet.models.pnet_kernel) against NumpyPnet's: the same bits, the
same dropout draws from the query's generator, on random networks of every shape the
export handles and on the shipped networks of every env."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet.models import load_pnet_checkpoint
from mpnet.models.networks import Normalizer, NumpyPnet, Pnet
from mpnet.models.pnet_kernel import PnetKernel
from mpnet.models.pretrained import SHIPPED, write_checkpoint


def _same_steps(net: NumpyPnet, rng: np.random.Generator, n: int = 30) -> None:
    kernel = PnetKernel(net)
    lo, hi = -2.0 * net.normalizer.scale, 2.0 * net.normalizer.scale
    z = rng.standard_normal(net._zdim).astype(np.float32)
    for i in range(n):
        x, goal = rng.uniform(lo, hi, net.state_dim), rng.uniform(lo, hi, net.state_dim)
        a, b = np.random.default_rng(i), np.random.default_rng(i)
        assert np.array_equal(net.step(z, x, goal, a), kernel.step(z, x, goal, b))
        assert a.random() == b.random()  # the same draws taken from the query's generator
        assert np.array_equal(net.step(z, x, goal, None), kernel.step(z, x, goal, None))  # dropout off


@settings(deadline=None, max_examples=25)
@given(
    seed=st.integers(0, 2**31 - 1),
    dim=st.sampled_from([2, 3, 7]),
    hidden=st.lists(st.integers(2, 40), min_size=1, max_size=4),
    dropout=st.sampled_from([0.0, 0.25, 0.3, 0.5]),  # 0.5 folds its scale into the weights
    alpha=st.sampled_from([0.25, -0.3, 1.5]),  # outside [0, 1]: PReLU as a select, not a max
    bounded=st.booleans(),  # softsign output, centred normaliser (a recipe option)
)
def test_the_compiled_step_is_numpys_bit_for_bit(seed, dim, hidden, dropout, alpha, bounded):
    torch.manual_seed(seed % 2**31)
    net = Pnet(8 + 2 * dim, dim, hidden, dropout=dropout, bounded=bounded).eval()
    for act in net.acts:
        torch.nn.init.constant_(act.weight, alpha)
    r = np.random.default_rng(seed)
    scale = r.uniform(0.5, 20.0, dim)
    offset = r.uniform(-3.0, 3.0, dim) if bounded else None
    _same_steps(NumpyPnet(net, Normalizer(scale, offset)), np.random.default_rng(seed))


def test_a_bounded_pnet_proposes_inside_the_bounds_in_torch_numpy_and_compiled():
    """The Panda's asymmetric joint limits: whatever the weights, every proposal of a bounded
    Pnet with the centred normaliser lies inside them (the unbounded one's do not)."""
    from mpnet.models import PnetModule
    from mpnet.models.networks import Enet

    lower = np.array([-2.9, -1.76, -2.9, -3.07, -2.9, -0.02, -2.9])
    upper = np.array([2.9, 1.76, 2.9, -0.07, 2.9, 3.75, 2.9])
    norm = Normalizer.centred(list(zip(lower, upper)))
    assert np.allclose(norm.normalize(lower), -1) and np.allclose(norm.normalize(upper), 1)
    assert np.allclose(norm.denormalize(norm.normalize((lower + upper) / 3)), (lower + upper) / 3)
    torch.manual_seed(0)
    rng = np.random.default_rng(0)
    for bounded in (True, False):
        net = Pnet(8 + 14, 7, (32, 16), dropout=0.3, bounded=bounded).eval()
        for lin in net.linears:
            torch.nn.init.normal_(lin.weight, std=2.0)  # outputs far outside [-1, 1] before softsign
        module = PnetModule(
            net, Enet(30, (16,), 8), state_scale=norm.to_list(), state_offset=norm.offset_list(), cloud_scale=1.0
        )
        numpy_net = NumpyPnet(net, norm)
        kernel = PnetKernel(numpy_net)
        z = rng.standard_normal(8).astype(np.float32)
        X, G = rng.uniform(lower, upper, (50, 7)), rng.uniform(lower, upper, (50, 7))
        with torch.no_grad():
            raw = module(
                torch.zeros(30), torch.as_tensor(X, dtype=torch.float32), torch.as_tensor(G, dtype=torch.float32)
            )
        outs = [raw.numpy(), numpy_net.step(z, X, G, rng)]
        outs.append(np.array([kernel.step(z, x, g, np.random.default_rng(i)) for i, (x, g) in enumerate(zip(X, G))]))
        inside = [bool(np.all((o >= lower) & (o <= upper))) for o in outs]
        assert inside == [bounded] * 3


@pytest.mark.parametrize("folder", sorted(SHIPPED.iterdir()), ids=lambda p: p.name)
def test_the_shipped_networks_step_the_same(folder, tmp_path):
    write_checkpoint(folder, tmp_path / "pnet.ckpt")
    _, step = load_pnet_checkpoint(tmp_path / "pnet.ckpt").to_numpy()
    _same_steps(step, np.random.default_rng(0), n=10)


def test_a_step_without_a_normaliser_or_of_the_wrong_shape_is_refused():
    net = Pnet(12, 2, (8,))
    with pytest.raises(ValueError, match="normaliser"):
        PnetKernel(NumpyPnet(net))
    with pytest.raises(ValueError, match="2 wide"):
        PnetKernel(NumpyPnet(Pnet(12, 2, (8, 1)), Normalizer(np.ones(2))))
    kernel = PnetKernel(NumpyPnet(net, Normalizer(np.ones(2))))
    with pytest.raises(ValueError, match="expected z"):
        kernel.step(np.zeros(8, np.float32), np.zeros(3), np.zeros(3))


def test_a_batch_of_rows_steps_as_one_state_does(tmp_path):
    """pnet_rows (batched planning): with dropout off each row is pnet_step's result (one matrix
    product instead of a vector product: equal up to float32 summation order); with dropout on,
    each row draws its own mask."""
    from mpnet.models.pnet_kernel import batch_scratch, pnet_rows

    write_checkpoint(SHIPPED / "s2d-quick", tmp_path / "pnet.ckpt")
    _, net = load_pnet_checkpoint(tmp_path / "pnet.ckpt").to_numpy()
    kernel = PnetKernel(net)
    rng = np.random.default_rng(0)
    z = rng.standard_normal(kernel.zdim).astype(np.float32)
    X, T = rng.uniform(-20, 20, (6, 2)), rng.uniform(-20, 20, (6, 2))
    out = np.empty((6, 2))
    buf = batch_scratch(kernel.layout, 6)
    pnet_rows(z, X, T, 6, *kernel.args, rng, False, buf, out)
    one = np.array([kernel.step(z, x, t, None) for x, t in zip(X, T)])
    np.testing.assert_allclose(out, one, rtol=1e-5, atol=1e-5)
    same = np.repeat(X[:1], 6, axis=0), np.repeat(T[:1], 6, axis=0)
    pnet_rows(z, *same, 6, *kernel.args, np.random.default_rng(1), True, buf, out)
    assert len({tuple(r) for r in out}) == 6  # six masks, six proposals from one state
    pnet_rows(z, *same, 3, *kernel.args, np.random.default_rng(1), True, buf, out)  # only the first m rows
