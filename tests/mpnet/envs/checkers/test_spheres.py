"""The arm's sphere model and compiled checker: the covering of the meshes, the kernels'
geometry against python-fcl, agreement with pybullet's mesh model, certified motions."""

from __future__ import annotations

import copy
import hashlib
import json

import fcl
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet.envs.arm.kinematics import forward
from mpnet.envs.arm.model import ArmModelError, load_arm_model
from mpnet.envs.arm.spherize import link_hull, spherize
from mpnet.envs.checkers import sphere_checks as C
from mpnet.envs.checkers import sphere_kernels as K
from mpnet.envs.checkers import sphere_layout as L
from mpnet.envs.checkers.spheres import pack_obstacles, read_spheres, sphere_model
from mpnet.envs.mbm.files import load_mbm
from mpnet.envs.shapes import Primitive
from mpnet.envs.specs import get_spec
from mpnet.envs.workspace import Workspace

ARM = get_spec("arm7")
MODEL = load_arm_model("panda")


def ws_of(*prims: Primitive) -> Workspace:
    return Workspace("t", "file", np.zeros((0, 3)), np.zeros((0, 3)), prims)


def test_every_mesh_link_has_spheres_made_from_the_meshes_shipped():
    doc = read_spheres(MODEL)
    assert set(doc["links"]) == {m.link for m in MODEL.kinematics.shapes}
    for mesh in MODEL.kinematics.shapes:
        assert doc["meshes"][mesh.link]["sha256"] == hashlib.sha256(mesh.path.read_bytes()).hexdigest()
    assert doc["pad"] > doc["spacing"]


@pytest.mark.parametrize("link", [m.link for m in MODEL.kinematics.shapes])
@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_spheres_cover_the_links_hull(link):
    """Every hull vertex and 20,000 random points of the hull lie inside one of the link's
    spheres, with at least a millimetre to spare (Bullet's margin)."""
    spheres = np.array(read_spheres(MODEL)["links"][link])
    hull = link_hull(MODEL, link)
    rng = np.random.default_rng(0)
    box = rng.uniform(hull.min_bound, hull.max_bound, (200_000, 3))
    inside = box[(box @ hull.equations[:, :3].T + hull.equations[:, 3] <= 0).all(axis=1)][:20_000]
    for pts in (hull.points[hull.vertices], inside):
        d = np.linalg.norm(pts[:, None, :] - spheres[None, :, :3], axis=2) - spheres[None, :, 3]
        assert d.min(axis=1).max() <= -0.001


def test_the_checkers_kinematics_are_the_models():
    """The sphere model's frames are the model's, posed by the one forward kinematics: its poses
    are link_transforms' to the last bit."""
    m = sphere_model("panda")
    pose = np.zeros((len(m.parent) + 1, 3, 4))
    rng = np.random.default_rng(1)
    for _ in range(20):
        q = ARM.space.sample(rng)
        forward(q, m.parent, m.origin, m.kind, m.axis, m.coord, pose)
        T = MODEL.link_transforms(q)
        assert np.array_equal(pose[:-1], T[:, :3, :]) and (T[:, 3] == [0.0, 0.0, 0.0, 1.0]).all()


def test_the_kernels_views_are_the_model_fields_the_layout_names():
    """The views (model_views, the counting twin of the kernels' unpack, generated from the same
    table) give back each field SphereModel packed, at its constant's index; the scratch's
    views tile it exactly; a field of the wrong shape is refused."""
    m = sphere_model("panda")
    views = L.model_views(m.mi, m.mf)
    assert len(views) == len(L.MODEL) and L.BOUND == len(L.MODEL) - 1
    for i, field in enumerate(L.MODEL):
        assert np.array_equal(views[i], getattr(m, field.name)), field.name
    scratch = L.scratch_views(m.mi, m.buffers())
    assert sum(v.size for v in scratch) == m.buffers().size
    assert scratch[L.POSE].shape == (len(m.parent) + 1, 3, 4) and scratch[L.T0S].size == L.QUEUE
    bad = copy.copy(m)
    bad.glever = m.glever[:, :-1]
    with pytest.raises(ValueError, match="glever"):
        L.pack(bad)


@settings(deadline=None, max_examples=40)
@given(st.integers(0, 10_000))
def test_levers_bound_how_far_spheres_move(seed):
    """No sphere moves farther than lever . |dq| between two configurations."""
    m = sphere_model("panda")
    rng = np.random.default_rng(seed)
    a = ARM.space.sample(rng)
    b = np.clip(a + rng.normal(0, 0.3, 7), ARM.lower, ARM.upper)
    moved = np.linalg.norm(m.world_spheres(b)[:, :3] - m.world_spheres(a)[:, :3], axis=1)
    assert (moved <= m.lever @ np.abs(b - a) + 1e-12).all()


def _table_pairs_overlap(m, q) -> bool:
    """Does any tabled self pair (tested sphere by sphere, in numpy) overlap at q?"""
    w = m.world_spheres(q)
    for pi in np.flatnonzero(m.pair_table >= 0):
        sa, sb = (w[m.sphere_link == x] for x in (m.pair_a[pi], m.pair_b[pi]))
        d = np.linalg.norm(sa[:, None, :3] - sb[None, :, :3], axis=2) - sa[:, None, 3] - sb[None, :, 3]
        if (d <= 0).any():
            return True
    return False


def test_the_wrist_pairs_are_tabled():
    m = sphere_model("panda")
    tabled = {(m.links[a], m.links[b]) for a, b, t in zip(m.pair_a, m.pair_b, m.pair_table) if t >= 0}
    wrist = {"panda_link7", "panda_hand", "panda_leftfinger", "panda_rightfinger"}
    assert tabled == {("panda_link5", x) for x in wrist}


@settings(deadline=None, max_examples=60)
@given(st.integers(0, 100_000))
def test_pair_tables_certify_whole_cells(seed):
    """Anywhere in a cell the table calls free (not only at its centre, where it was
    tested), with any other joints, the tabled pairs' spheres do not overlap; and the
    kernels' lookup agrees with the table's bits."""
    m = sphere_model("panda")
    (ja, jb, na, nb, _), (lo_a, wa, lo_b, wb) = m.table_i[0], m.table_f[0]
    bits = np.unpackbits(m.table_bits.view(np.uint8), bitorder="little")[: na * nb].reshape(na, nb)
    rng = np.random.default_rng(seed)
    free_cells = np.argwhere(bits == 1)
    near_cells = np.argwhere(bits == 0)
    for cells, free in ((free_cells, True), (near_cells, False)):
        i, k = cells[rng.integers(len(cells))]
        q = ARM.space.sample(rng)
        q[ja] = lo_a + (i + rng.uniform()) * wa
        q[jb] = lo_b + (k + rng.uniform()) * wb
        looked_up = K._table_free(q, m.table_i[0], m.table_f[0], m.table_sum, 0.0, np.zeros(7))
        assert looked_up == free
        if free:
            assert not _table_pairs_overlap(m, q)


@settings(deadline=None, max_examples=60)
@given(st.integers(0, 100_000))
def test_a_pair_table_answers_a_box_of_any_size_as_its_cells_do(seed):
    """The lookup over a motion interval (a box of cells, from one to the whole table) is
    free exactly when every cell in the box is free by the table's bits (the summed-area
    counts stand in for reading each cell)."""
    m = sphere_model("panda")
    (ja, jb, na, nb, _), (lo_a, wa, lo_b, wb) = m.table_i[0], m.table_f[0]
    bits = np.unpackbits(m.table_bits.view(np.uint8), bitorder="little")[: na * nb].reshape(na, nb)
    rng = np.random.default_rng(seed)
    q, dq = ARM.space.sample(rng), np.abs(rng.normal(0, 1, 7))
    h = rng.choice([0.0, 1e-3, 0.05, 0.5, 5.0]) * rng.uniform()
    cell = lambda v, lo, w, n: int(np.clip(np.floor((v - lo) / w), 0, n - 1))  # noqa: E731
    i0, i1 = (cell(q[ja] + s * h * dq[ja], lo_a, wa, na) for s in (-1, 1))
    k0, k1 = (cell(q[jb] + s * h * dq[jb], lo_b, wb, nb) for s in (-1, 1))
    expected = bool(bits[i0 : i1 + 1, k0 : k1 + 1].all())
    assert K._table_free(q, m.table_i[0], m.table_f[0], m.table_sum, h, dq) == expected


def _fcl_shape(p: Primitive):
    if p.type == "box":
        return fcl.Box(*p.size)
    if p.type == "cylinder":
        return fcl.Cylinder(p.radius, p.height)
    return fcl.Sphere(p.radius)


@settings(deadline=None, max_examples=150)
@given(
    st.sampled_from(["box", "cylinder", "sphere"]),
    st.lists(st.floats(0.02, 0.5), min_size=3, max_size=3),
    st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1),
    st.lists(st.floats(-0.6, 0.6), min_size=3, max_size=3),
    st.floats(0.005, 0.1),
)
def test_sphere_against_a_primitive_agrees_with_fcl(kind, dims, quat, centre, radius):
    size = {"box": dims, "cylinder": [dims[0], dims[0], dims[1]], "sphere": [dims[0]] * 3}[kind]
    p = Primitive(kind, (0.0, 0.0, 0.0), size, quat)
    tf = fcl.Transform(p.rotation(), np.array(p.center))
    obj, ball = fcl.CollisionObject(_fcl_shape(p), tf), fcl.CollisionObject(fcl.Sphere(radius), fcl.Transform(centre))
    gap = fcl.distance(obj, ball, fcl.DistanceRequest(), fcl.DistanceResult())
    if abs(gap) < 1e-6:  # touching: either answer is within rounding
        return
    ob = pack_obstacles(ws_of(p), 0.0)
    hit = C.any_hit(np.array([centre], float), np.array([radius]), ob)
    assert hit == (gap < 0)
    # The axis-aligned bounds the kernels reject with first never reject a touching sphere.
    bounds = K.obstacle_views(ob)[4]
    if K._outside(np.array([centre], float), 0, bounds, 0, radius):
        assert gap > 0


def _scenes(mbm_dir):
    return load_mbm(mbm_dir, ARM).workspaces + [ARM.generator.make(i, "seen") for i in range(4)]


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_spheres_never_call_free_what_pybullet_calls_colliding(mbm_dir):
    """20,000 random configurations in MotionBenchMaker's and arm7's scenes: none that the
    spheres call free and pybullet's meshes (same fingers, no margin) call colliding; the
    spheres reject some free ones (they are a covering), but few."""
    rng = np.random.default_rng(2)
    rejected = free = 0
    for ws in _scenes(mbm_dir):
        qs = np.array([ARM.space.sample(rng) for _ in range(2000)])
        s = ARM.make_checker(ws, margin=0.0, backend="spheres").states_valid(qs)
        p = ARM.make_checker(ws, margin=0.0, backend="pybullet").states_valid(qs)
        assert not (s & ~p).any(), ws.id
        rejected += int((p & ~s).sum())
        free += int(p.sum())
    assert rejected / free < 0.15


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_free_motions_are_free_at_ten_times_finer_sampling(mbm_dir):
    """Every motion the checker calls free, sampled 10x finer than 0.02 rad (the old
    sampled step) with the sphere state check: no state collides."""
    rng = np.random.default_rng(3)
    n_free = 0
    for ws in _scenes(mbm_dir):
        ch = ARM.make_checker(ws, margin=0.0)
        qs = np.array([ARM.space.sample(rng) for _ in range(1500)])
        ok = qs[ch.states_valid(qs)]
        a = ok[rng.integers(0, len(ok), 300)]
        b = np.clip(a + rng.normal(0, 0.4, a.shape), ARM.lower, ARM.upper)
        for x, y in zip(a[ch.motions_valid(a, b)], b[ch.motions_valid(a, b)]):
            n = int(np.ceil(np.linalg.norm(y - x) / 0.002)) + 1
            states = x + np.linspace(0, 1, n)[:, None] * (y - x)
            states[-1] = y  # x + 1.0 (y - x) can round past a joint limit y sits on
            assert ch.states_valid(states).all()
            n_free += 1
    assert n_free > 300


def test_a_thin_plate_between_samples_blocks_the_motion():
    """The failure sampled motions had: a 2 mm plate the hand crosses between two states
    0.02 rad apart. Certified motions catch it however short the crossing."""
    home = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    a, b = home.copy(), home.copy()
    a[0], b[0] = -0.6, 0.6
    hand = MODEL.end_effector_position(home)
    plate = Primitive("box", (hand[0], 0.0, hand[2]), (0.1, 0.002, 0.05))
    ch = ARM.make_checker(ws_of(plate), margin=0.0)
    assert ch.is_valid(a) and ch.is_valid(b)
    assert not ch.motion_valid(a, b) and not ch.motions_valid([a], [b])[0]


def test_batch_and_single_calls_agree(mbm_dir):
    ws = load_mbm(mbm_dir, ARM).workspaces[0]
    ch = ARM.make_checker(ws)
    rng = np.random.default_rng(4)
    qs = np.array([ARM.space.sample(rng) for _ in range(300)])
    assert list(ch.states_valid(qs)) == [ch.is_valid(q) for q in qs.tolist()]
    a, b = qs[:100], qs[100:200]
    assert list(ch.motions_valid(a, b)) == [ch.motion_valid(x, y) for x, y in zip(a.tolist(), b.tolist())]


def _model_copy(tmp_path, monkeypatch):
    """The package's robot descriptions copied into tmp_path, which load_arm_model then reads."""
    from mpnet.envs.arm import model as arm_model

    for f in arm_model._data_dir().iterdir():
        if f.is_file():
            (tmp_path / f.name).write_bytes(f.read_bytes())
    monkeypatch.setattr(arm_model, "_data_dir", lambda: tmp_path)
    return tmp_path


def test_an_unknown_or_broken_model_is_named(tmp_path, monkeypatch):
    with pytest.raises(
        ArmModelError, match="unknown arm model 'nope'; choices: fetch, panda, panda_pybullet_data, ur5"
    ):  # noqa: E501
        load_arm_model("nope")
    folder = _model_copy(tmp_path, monkeypatch)
    desc = folder / "panda.yaml"
    text = desc.read_text()
    desc.write_text(text.replace("end_effector:", "end_effectr:"))
    read = load_arm_model.__wrapped__  # the uncached reader: the package's model stays cached
    with pytest.raises(ArmModelError, match=r"panda.yaml: missing or malformed key 'end_effector'"):
        read("panda")
    desc.write_text(text.replace("  - [-2.8973, 2.8973]\n", "  - [2.8973, -2.8973]\n", 1))
    with pytest.raises(ArmModelError, match="panda.yaml: limits must be one"):
        read("panda")


def test_the_model_digest_names_both_files(tmp_path, monkeypatch):
    """The digest is sha256 of the description then the sphere file; an edit of either changes it."""
    digest = MODEL.digest()
    assert len(digest) == 16 and MODEL.to_json()["sha256"] == digest
    assert json.loads(json.dumps(MODEL.to_json()))["fingers"]["panda_finger_joint1"] == 0.065
    folder = _model_copy(tmp_path, monkeypatch)
    both = (folder / "panda.yaml").read_bytes() + (folder / MODEL.spheres).read_bytes()
    assert digest == hashlib.sha256(both).hexdigest()[:16]
    seen = {digest}
    for name in ("panda.yaml", MODEL.spheres):
        f = folder / name
        before = f.read_bytes()
        f.write_bytes(before + b"\n")
        seen.add(MODEL.digest())
        f.write_bytes(before)
    assert len(seen) == 3 and MODEL.digest() == digest


def test_a_log_names_the_model_it_was_judged_with():
    """Logs from before arm models were data ({"fingers": 0.04}) re-check with pybullet_data's
    Panda as it was then: its URDF limits and fingers; new logs name their model."""
    old = ARM.for_logged_robot({"kind": "arm", "name": "panda", "urdf": "franka_panda/panda.urdf", "fingers": 0.04})
    assert old.robot.model.name == "panda_pybullet_data" and old.bounds == MODEL.kinematics.urdf_limits
    assert old.judge_checker(ws_of()).is_valid([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    assert ARM.for_logged_robot(ARM.robot_json()) is ARM


def test_the_model_and_checker_version_are_in_every_arm_cache_key():
    """Data built with another arm model, sphere set or checker version is another artifact."""
    ident = ARM.robot.cache_identity()
    assert ident == {"robot": f"panda:{MODEL.digest()}", "checker": "spheres@3"}
    assert get_spec("s2d").robot.cache_identity() == {}


@pytest.mark.slow
def test_sphere_audit_cli(run_cli, mbm_dir, tmp_path):
    out = tmp_path / "audit"
    args = ("--problems", str(mbm_dir), "--configurations", "1200", "--motions", "60")
    p = run_cli("harness.sphere_audit", *args, "--out", str(out))
    lines = p.stdout.splitlines()
    assert lines[0].startswith("1,200 configurations in 6 scenes: 0 called free by the spheres and colliding")
    assert lines[1].startswith("60 motions: ") and " 0 of them colliding at 0.002 rad" in lines[1]
    assert lines[2].startswith("6 queries (start and goal): ") and ", 0 for the spheres only, " in lines[2]
    report = (out / "README.md").read_text()  # what FINDINGS quotes: with its provenance
    assert "Generated by `python -m harness.sphere_audit --problems " in report and "at git " in report
    assert lines[0] in report
    bad = run_cli("harness.sphere_audit", "--problems", str(mbm_dir / "nope"), check=False)
    assert bad.returncode == 2 and "no such file or folder" in bad.stderr
    bad = run_cli("harness.sphere_audit", "--env", "nope", check=False)
    assert bad.returncode == 2 and bad.stderr.startswith("error: unknown env 'nope'; choices: ")


@pytest.mark.slow
def test_the_shipped_set_is_what_the_builder_makes():
    """The fingers' and hand's spheres rebuilt from the meshes with the recorded settings equal
    the shipped ones (the whole set: `python -m harness.spherize`, ~3 minutes)."""
    shipped = read_spheres(MODEL)
    links = ("panda_leftfinger", "panda_rightfinger", "panda_hand")
    doc = spherize(MODEL, {k: shipped["reach"][k] for k in links}, shipped["spacing"], shipped["pad"], shipped["seed"])
    assert set(doc["links"]) == set(links)
    for k in links:
        assert np.allclose(doc["links"][k], shipped["links"][k])


@pytest.mark.slow
def test_spherize_cli_names_an_unknown_model(run_cli):
    bad = run_cli("harness.spherize", "nope", check=False)
    assert bad.returncode == 2 and "unknown arm model 'nope'" in bad.stderr


def test_pybullet_forgets_the_previous_configurations_contacts(repo):
    """A free configuration checked right after a colliding one read as colliding (a point of
    Bullet's persistent contact manifold survived the move); found by the 1,000,000-state
    audit, one in ~125,000."""
    ws = load_mbm(repo / "tests" / "data" / "mbm_stale_contact", ARM).workspaces[0]
    before = [-1.102953999547015, -1.7175310960757126, 1.8132428731005077, -0.9748669459253554,
              0.6213092540110021, 0.4890924050060473, 2.218772704726564]  # fmt: skip
    q = [-0.9388712310771035, -0.014255130613419764, -1.9902833502996198, -0.9591919048111173,
         -1.8600407517310211, 1.2149187898609937, 2.2803267557864877]  # fmt: skip
    ch = ARM.make_checker(ws, margin=0.0, backend="pybullet")
    assert ch.is_valid(q)
    assert not ch.is_valid(before) and ch.is_valid(q)
    assert list(ch.states_valid([before, q])) == [False, True]
