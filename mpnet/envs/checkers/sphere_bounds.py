"""How far a sphere can move in a motion interval (numba): the two bounds the sphere checker's
certified motions grow its spheres by, a model's `bound` choosing one.

Along a straight joint motion q(t) = a + t (b - a), in the interval [m - h, m + h]:

- LEVER (the `spheres` checker, VERSION 3): a point moves at most
  h sum_j |dq_j| (rho_j + r) + h^2 / 2 B, rho_j its distance from joint j's axis at m, r the
  sphere's radius, B = sum_j |dq_j| sum_{k > j} |dq_k| (R_k + r) (rho_j changes only through
  the joints after j, R_k the static levers: the lengths of the fixed offsets from joint k to
  the point). Every joint counts by its size, the ones that do not move the sphere too.
- SWEPT (the `spheres_swept` checker): the sphere's velocity at m summed as a vector over the
  joints that move it (coordinates below its frame's `nj`), v = sum_j dq_j u_j x (c - a_j)
  (prismatic: dq_j u_j), and its spin omega = sum_j dq_j u_j (revolute): a point within r of c
  moves at most h (|v| + r |omega|) + h^2 / 2 A, with
      A = sum_{j, k} |dq_j| |dq_k| (R_max(j, k) + r)
  over the joints that move it, since d v / dt = sum_j dq_j sum_k dq_k d w_j / d q_k with
  w_j = u_j x (p - a_j), |d w_j / d q_k| <= R_j when k <= j (joint k turns w_j, or p about
  u_j) and <= R_k when k > j (p moves by w_k). On the Panda the first-order term is about half
  LEVER's for the distal links and a tenth or less for the proximal ones; the second-order
  term is about twice LEVER's, so a long interval can grow more, a short one much less: an
  arm's motion is certified in about a third fewer configurations.

Relative to an ancestor link (a self-collision pair) either bound counts only the joints from
the first one between them (j0): the others move both links together. Both are sound (the
checker's tests hold them to sampled motions); their answers differ only where a motion
passes within the certification's tolerance of a contact (a motion gives up there).
"""

from __future__ import annotations

import math

from mpnet.jit import njit

LEVER, SWEPT = 0, 1  # SphereModel.bound


@njit(cache=True, borrowed=True)
def lever_second_order(lever, rad, dq, out):
    """LEVER's B per row: sum_j |dq_j| sum_{k > j} |dq_k| (R_k + rad)."""
    D = dq.shape[0]
    for i in range(lever.shape[0]):
        later, s = 0.0, 0.0
        for j in range(D - 1, -1, -1):
            s += dq[j] * later
            later += dq[j] * (lever[i, j] + rad[i])
        out[i] = s


@njit(cache=True, borrowed=True)
def swept_second_order(lever, rad, nj, dq, out):
    """SWEPT's A per row and first joint: out[i, j0] over the joints j0 .. nj[i] - 1."""
    for i in range(lever.shape[0]):
        s, later = 0.0, 0.0  # A over j0 + 1 ..; the sum over them of |dq_k| (R_k + r)
        for j0 in range(nj[i] - 1, -1, -1):
            reach = (lever[i, j0] + rad[i]) * dq[j0]
            s += dq[j0] * (reach + 2.0 * later)  # the pairs (j0, j0), (j0, k) and (k, j0), k > j0
            later += reach
            out[i, j0] = s


# The growth helpers are inlined (numba's IR): called hundreds of times a verdict with the
# motion's tuple, they were a tenth of a motion check as calls. Inlining more (the placements,
# the tests) made every kernel that inlines the checks compile ~3x longer (a first arm command
# 70 -> 204 s) for no measured gain. grow = (h, |dq| (D,), the joints' axes now: points (D, 3),
# directions (D, 3), prismatic flags (D,); dq signed (D,)).
@njit(cache=True, borrowed=True, inline="always")
def _speed(c, i, rad, j, grow):
    """How fast a point within rad of c[i] moves per unit of joint j's step: its distance
    from joint j's axis now plus rad (1 for a prismatic joint)."""
    _, dq, ap, au, pris, _ = grow
    if pris[j] != 0.0:
        return 1.0
    vx, vy, vz = c[i, 0] - ap[j, 0], c[i, 1] - ap[j, 1], c[i, 2] - ap[j, 2]
    t = vx * au[j, 0] + vy * au[j, 1] + vz * au[j, 2]
    rho2 = vx * vx + vy * vy + vz * vz - t * t
    return math.sqrt(rho2 if rho2 > 0.0 else 0.0) + rad[i]


@njit(cache=True, borrowed=True, inline="always")
def _lever(c, i, rad, Bv, grow, sp):
    """LEVER: h sum_j |dq_j| (rho_j + rad) + h^2 / 2 B. Each joint's speed is kept in sp[i]
    for _lever_from (a square root per joint: the same number, not computed twice)."""
    h, dq = grow[0], grow[1]
    a = 0.0
    for j in range(dq.shape[0]):
        if dq[j] != 0.0:
            sp[i, j] = _speed(c, i, rad, j, grow)
            a += dq[j] * sp[i, j]
    return h * a + 0.5 * h * h * Bv[i]


@njit(cache=True, borrowed=True, inline="always")
def _lever_from(sp, i, rad, lever, j0, grow):
    """_lever counting only joints j0.., from the speeds _lever kept in sp[i], its
    second-order term computed here from the static levers."""
    h, dq = grow[0], grow[1]
    first, later, second = 0.0, 0.0, 0.0
    for j in range(dq.shape[0] - 1, j0 - 1, -1):
        second += dq[j] * later
        later += dq[j] * (lever[i, j] + rad[i])
        if dq[j] != 0.0:
            first += dq[j] * sp[i, j]
    return h * first + 0.5 * h * h * second


@njit(cache=True, borrowed=True, inline="always")
def _swept(c, i, rad, nj, grow, second, rel):
    """SWEPT through every joint that moves row i, and through joints j0.. for each j0 into
    rel[i, j0] (summed from the last joint back: one pass for all of them)."""
    h, _, ap, au, pris, sdq = grow
    vx, vy, vz, wx, wy, wz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for j in range(nj[i] - 1, -1, -1):
        d = sdq[j]
        ux, uy, uz = au[j, 0], au[j, 1], au[j, 2]
        if pris[j] != 0.0:
            vx += d * ux
            vy += d * uy
            vz += d * uz
        else:
            rx, ry, rz = c[i, 0] - ap[j, 0], c[i, 1] - ap[j, 1], c[i, 2] - ap[j, 2]
            vx += d * (uy * rz - uz * ry)
            vy += d * (uz * rx - ux * rz)
            vz += d * (ux * ry - uy * rx)
            wx += d * ux
            wy += d * uy
            wz += d * uz
        first = math.sqrt(vx * vx + vy * vy + vz * vz) + rad[i] * math.sqrt(wx * wx + wy * wy + wz * wz)
        rel[i, j] = h * first + 0.5 * h * h * second[i, j]
    return rel[i, 0] if nj[i] > 0 else 0.0


@njit(cache=True, borrowed=True, inline="always")
def growth(bound, c, i, rad, nj, grow, sp, lever_b, swept_a, rel):
    """How far any point within rad[i] of c[i] can move in the current interval, by `bound`
    (sp: LEVER's speeds, rel: SWEPT's growth from each joint on, kept for growth_from;
    lever_b, swept_a: the second-order terms)."""
    if bound == SWEPT:
        return _swept(c, i, rad, nj, grow, swept_a, rel)
    return _lever(c, i, rad, lever_b, grow, sp)


@njit(cache=True, borrowed=True, inline="always")
def growth_from(bound, i, rad, lever, j0, grow, sp, rel):
    """growth through joints j0.. only (how far a point of a link moves relative to an
    ancestor link: the joints between them are j0 and the ones after it), from what growth
    kept of row i."""
    if bound == SWEPT:
        return rel[i, j0]
    return _lever_from(sp, i, rad, lever, j0, grow)


@njit(cache=True, borrowed=True)
def growths(bound, c, rad, nj, grow, sp, lever_b, swept_a, rel, out):
    """growth of every row into out: one call, so that the kernels that inline a verdict
    compile the bounds once (each inlined copy made a first arm command compile ~40% longer)."""
    for i in range(out.shape[0]):
        out[i] = growth(bound, c, i, rad, nj, grow, sp, lever_b, swept_a, rel)
