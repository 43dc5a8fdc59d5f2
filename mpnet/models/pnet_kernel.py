"""Pnet's step compiled (numba), for the compiled planner: the same operations as
NumpyPnet's one-state step, in the same order and precision, so the same bits.

Why numba: a batch-1 step is a handful of small matrix-vector products; numpy's ~25 calls
per step cost more than the products themselves (perf.md: a quick step at 2.1x its matmul
floor). Compiled, the step is the products (np.dot: the same BLAS sgemv numpy calls, so the
same sums) plus a few loops, and the compiled planner calls it without Python between.

The dropout masks are drawn from the query's own np.random.Generator inside the kernel
(numba draws PCG64's stream as numpy does): one draw of all masks per step, as NumpyPnet.

The layers travel as one flat array each (weights, dropout weights, biases) and a `layout`
table, not a tuple of arrays: numba types a tuple by its length, so every network depth
compiled the planner's loops again (about 20 s each for an arm); a layer is a contiguous view
of its flat array, so np.dot takes the same BLAS call on the same numbers.
"""

from __future__ import annotations

import numpy as np

from mpnet.jit import njit


class PnetKernel:
    """A NumpyPnet's arrays as the kernel takes them (`args`), and `step(z, x, goal, rng)`
    with NumpyPnet's meaning: rng None is dropout off; x and goal raw states when the net
    has a normaliser."""

    def __init__(self, net):
        if net.normalizer is None:
            raise ValueError("the compiled step takes raw states: export the Pnet with its normaliser")
        if any(w.shape[1] == 1 for w in net.weights):  # numpy takes a dot product there: other sums
            raise ValueError("the compiled step needs every layer at least 2 wide (numpy sums a 1-wide one otherwise)")
        self.layout = layout(net.weights)
        self.args = (
            flat(net.weights),
            flat(net._dropout_weights if net._fold else net.weights),
            flat(net.biases),
            np.asarray(net.alphas, np.float32),
            np.float32(net.p),
            np.float32(1.0 if net._fold else net.keep_scale),  # the masks' scale (1: folded into weights)
            np.asarray(net._offsets, np.int64),
            np.asarray(net._shift2, np.float32),
            np.asarray(net._inv2, np.float32),
            np.asarray(net._out, np.float64),
            np.asarray(net._out_off, np.float64),
            bool(net.bounded),
            bool(net._prelu_max),
            self.layout,
        )
        self.zdim, self.state_dim = net._zdim, net.state_dim
        self.buffers = scratch(self.layout)  # the step's work arrays, reused by every call (and the planner)
        self._off = np.random.default_rng(0)  # never drawn from: stands in for "no rng"

    def step(self, z, x, goal, rng: np.random.Generator | None = None) -> np.ndarray:
        z = np.asarray(z, np.float32)
        x, goal = np.asarray(x, np.float64), np.asarray(goal, np.float64)
        if z.shape != (self.zdim,) or x.shape != (self.state_dim,) or goal.shape != (self.state_dim,):
            raise ValueError(
                f"expected z ({self.zdim},), x and goal ({self.state_dim},); got {z.shape}, {x.shape}, {goal.shape}"
            )
        out = np.empty(self.state_dim, np.float64)
        pnet_step(z, x, goal, *self.args, rng if rng is not None else self._off, rng is not None, self.buffers, out)
        return out

    __call__ = step


ROWS, COLS, W_AT, B_AT = range(4)  # layout's columns: a layer's weight shape, where it starts in each flat array


def flat(arrays) -> np.ndarray:
    """The layers' arrays, each in C order, one after another (float32)."""
    return np.concatenate([np.ascontiguousarray(a, np.float32).ravel() for a in arrays])  # float32 in, float32 out


def layout(weights) -> np.ndarray:
    """Per layer (in, out, its weights' start in the flat weights, its biases' and outputs' start)."""
    shapes = np.array([w.shape for w in weights], np.int64)
    sizes = shapes[:, 0] * shapes[:, 1]
    starts = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    outs = np.concatenate(([0], np.cumsum(shapes[:, 1])[:-1]))
    return np.ascontiguousarray(np.column_stack([shapes, starts, outs]), np.int64)


def scratch(lay: np.ndarray) -> tuple:
    """The step's buffers: the input, every layer's output (float32, one flat array at the
    layout's output starts), and the masks."""
    cols = lay[:, COLS]
    return (np.empty(lay[0, ROWS], np.float32), np.empty(cols.sum(), np.float32), np.empty(cols[:-1].sum(), np.float32))


@njit(cache=True, inline="always")
def _weights(flat_w, lay, k):
    """Layer k's weights: a C-contiguous (in, out) view of the flat array."""
    r, c, at = lay[k, ROWS], lay[k, COLS], lay[k, W_AT]
    return flat_w[at : at + r * c].reshape((r, c))


@njit(cache=True)
def affine(src, w, b, o):
    """o = src @ w + b, as numpy's `h @ w` then `h += b` (np.dot: the same BLAS sgemv)."""
    o[:] = np.dot(src, w)
    for j in range(o.shape[0]):
        o[j] += b[j]


@njit(cache=True)
def prelu(v, a, prelu_max):
    """NumpyPnet's PReLU of one float32: max(v, a v) when 0 <= a <= 1, else its select."""
    if prelu_max:
        t = v * a
        return v if v >= t else t
    return v * ((np.float32(1.0) if v < 0 else np.float32(0.0)) * (a - np.float32(1.0)) + np.float32(1.0))


@njit(cache=True)
def output(o, i, out_scale, out_off, bounded):
    """Output i's float32 value -> the raw state's coordinate, as NumpyPnet._output: softsign
    if bounded (in float64), times the scale, plus the offset (0 unless centred: x + 0.0 is x)."""
    v = np.float64(o)
    if bounded:
        v = v / (1.0 + abs(v))
    return v * out_scale[i % out_scale.shape[0]] + out_off[i]


@njit(cache=True)
def pnet_step(  # the net's arrays unpacked: a kernel takes no objects
    z,
    x,
    goal,
    plain,
    dropped,
    biases,
    alphas,
    p,
    mask_scale,
    offsets,
    shift2,
    inv2,
    out_scale,
    out_off,
    bounded,
    prelu_max,
    lay,
    rng,
    dropout,
    buf,
    out,
):
    """out = Pnet(z, x, goal), as NumpyPnet._step1 computes it (see the module docstring):
    `dropped` are the weights used with dropout on (with its 1/(1-p) folded in where exact)."""
    h, layers, masks = buf
    zd, d = z.shape[0], x.shape[0]
    for i in range(zd):
        h[i] = z[i]
    for i in range(d):
        h[zd + i] = (np.float32(x[i]) - shift2[i]) * inv2[i]
        h[zd + d + i] = (np.float32(goal[i]) - shift2[d + i]) * inv2[d + i]
    n_dropout = offsets.shape[0] - 1
    n_mask = offsets[n_dropout]
    weights = dropped if dropout and n_mask > 0 else plain
    if dropout and n_mask > 0:
        one = np.float32(1.0) * mask_scale  # NumpyPnet: a 1.0 mask times keep_scale, unless folded
        u = rng.random(n_mask, dtype=np.float32)
        for i in range(n_mask):
            masks[i] = one if u[i] >= p else np.float32(0.0)
    last = lay.shape[0] - 1
    src = h
    for k in range(last + 1):
        c, at = lay[k, COLS], lay[k, B_AT]
        o = layers[at : at + c]
        affine(src, _weights(weights, lay, k), biases[at : at + c], o)
        if k == last:
            break
        a = alphas[k]
        for j in range(o.shape[0]):
            o[j] = prelu(o[j], a, prelu_max)
        if dropout and k < n_dropout and n_mask > 0:
            base = offsets[k]
            for j in range(o.shape[0]):
                o[j] *= masks[base + j]
        src = o
    o = layers[lay[last, B_AT] :]
    for i in range(d):
        out[i] = output(o[i], i, out_scale, out_off, bounded)


def batch_scratch(lay: np.ndarray, rows: int) -> tuple:
    """pnet_rows' buffers for up to `rows` states: the inputs, every layer's outputs (one flat
    array, layer k's rows from rows x its output start), the masks."""
    cols = lay[:, COLS]
    n_in, n_mask = lay[0, ROWS], cols[:-1].sum()
    return (
        np.empty((rows, n_in), np.float32),
        np.empty(rows * cols.sum(), np.float32),
        np.empty((rows, n_mask), np.float32),
    )


@njit(cache=True)
def pnet_rows(z, X, T, m, plain, dropped, biases, alphas, p, mask_scale, offsets, shift2, inv2, out_scale, out_off,
              bounded, prelu_max, lay, rng, dropout, buf, out):  # fmt: skip
    """out[:m] = Pnet(z, X[r], T[r]) for the first m rows as one matrix product per layer (batched
    planning): pnet_step's operations on rows, each row its own dropout mask (one draw of all
    rows' masks per call), so a row's result is what pnet_step gives with that row's mask."""
    H, layers, masks = buf
    zd, d = z.shape[0], X.shape[1]
    for r in range(m):
        for i in range(zd):
            H[r, i] = z[i]
        for i in range(d):
            H[r, zd + i] = (np.float32(X[r, i]) - shift2[i]) * inv2[i]
            H[r, zd + d + i] = (np.float32(T[r, i]) - shift2[d + i]) * inv2[d + i]
    n_dropout = offsets.shape[0] - 1
    n_mask = offsets[n_dropout]
    on = dropout and n_mask > 0
    weights = dropped if on else plain
    if on:
        one = np.float32(1.0) * mask_scale
        u = rng.random((m, n_mask), dtype=np.float32)
        for r in range(m):
            for i in range(n_mask):
                masks[r, i] = one if u[r, i] >= p else np.float32(0.0)
    last, cap = lay.shape[0] - 1, H.shape[0]
    src = H[:m]
    for k in range(last + 1):
        c, at = lay[k, COLS], lay[k, B_AT]
        o = layers[cap * at : cap * at + m * c].reshape((m, c))
        o[:, :] = np.dot(src, _weights(weights, lay, k))
        b = biases[at : at + c]
        a = alphas[k] if k < last else np.float32(0.0)
        for r in range(m):
            for j in range(o.shape[1]):
                v = o[r, j] + b[j]
                if k < last:
                    v = prelu(v, a, prelu_max)
                    if on and k < n_dropout:
                        v *= masks[r, offsets[k] + j]
                o[r, j] = v
        src = o
    c, at = lay[last, COLS], lay[last, B_AT]
    o = layers[cap * at : cap * at + m * c].reshape((m, c))
    for r in range(m):
        for i in range(d):
            out[r, i] = output(o[r, i], i, out_scale, out_off, bounded)
