"""arm7: the arm model as data, both checkers (spheres and pybullet) on posed primitives, the
scene generator, problems@2 and MotionBenchMaker's problems."""

from __future__ import annotations

import gc
import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet.envs.arm.model import load_arm_model
from mpnet.envs.checkers.pybullet_arm import PybulletArmChecker, coarse_to_fine, lent_world
from mpnet.envs.mbm.files import load_mbm
from mpnet.envs.shapes import Primitive, quat_matrix, surface_cloud, yaw_quat
from mpnet.envs.specs import get_spec
from mpnet.envs.workspace import Workspace
from mpnet.motion import verify_path
from mpnet.problems import FORMAT_2, ProblemFileError, dump_problems, load_problems

ARM = get_spec("arm7")
HOME = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]  # MotionBenchMaker's start
BACKENDS = ("spheres", "pybullet")


def ws_of(*prims: Primitive, wid: str = "t") -> Workspace:
    return Workspace(wid, "file", np.zeros((0, 3)), np.zeros((0, 3)), prims)


EMPTY = ws_of()


def hand_position(q=HOME) -> np.ndarray:
    with lent_world(load_arm_model("panda")) as w:
        return np.array(w.hand_position(q))


@pytest.fixture(params=BACKENDS)
def checker(request):
    """make_checker(ws, margin=None) of one backend."""
    return lambda ws, margin=None: ARM.make_checker(ws, margin=margin, backend=request.param)


def test_limits_are_motionbenchmakers():
    """MoveIt's limits (the URDF's soft limits), not the URDF's hard limits."""
    model = load_arm_model("panda")
    assert ARM.bounds == model.limits and ARM.state_dim == 7 and ARM.workspace_dim == 3
    assert model.limits[1] == (-1.7628, 1.7628) and model.kinematics.urdf_limits[1] == (-1.8326, 1.8326)
    assert model.fingers == {"panda_finger_joint1": 0.065, "panda_finger_joint2": 0.065}
    assert load_arm_model("panda_pybullet_data").limits == model.kinematics.urdf_limits


def test_pybullet_allows_the_models_pairs_only():
    """The pairs pybullet ignores are the model's (MotionBenchMaker's allowed collision matrix)."""
    with lent_world(load_arm_model("panda")) as world:
        names = {tuple(sorted((world.link_names[a], world.link_names[b]))) for a, b in world.allowed}
    assert names == set(load_arm_model("panda").allowed)
    assert len(names) == 34


def test_bullet_never_pairs_the_allowed_links_and_the_verdicts_stay():
    """Bullet skips the allowed pairs (paired, some touch), each verdict as with them paired."""
    qs = [ARM.space.sample(rng) for rng in [np.random.default_rng(1)] for _ in range(300)]
    with lent_world(load_arm_model("panda")) as w:
        pb, r, c = w.pb, w.robot, w.client

        def contacts():  # the allowed pairs Bullet reports touching at any of qs
            found = set()
            for q in qs:
                w.set_q(q)
                pb.performCollisionDetection(physicsClientId=c)
                found |= {(min(p[3], p[4]), max(p[3], p[4])) for p in pb.getContactPoints(r, r, physicsClientId=c)}
            return found & w.allowed

        skipped, unpaired = [w.collides(q) for q in qs], contacts()
        try:
            for a, b in w.allowed:  # paired again: collides() filters their contacts itself
                pb.setCollisionFilterPair(r, r, a, b, 1, physicsClientId=c)
            paired, seen = [w.collides(q) for q in qs], contacts()
        finally:
            for a, b in w.allowed:
                pb.setCollisionFilterPair(r, r, a, b, 0, physicsClientId=c)
    assert not unpaired and seen and skipped == paired and 0 < sum(skipped) < len(qs)


def test_forward_kinematics_match_pybullet():
    model = load_arm_model("panda")
    rng = np.random.default_rng(0)
    with lent_world(model) as world:
        for _ in range(20):
            q = ARM.space.sample(rng)
            poses = world.link_poses(q)  # inertial frames; the hand's link frame via hand_position
            assert np.allclose(model.end_effector_position(q), world.hand_position(q), atol=1e-6)
            assert len(poses) == len(world.links)


def test_self_collision_is_checked(checker):
    ch = checker(EMPTY)
    rng = np.random.default_rng(0)
    ok = ch.states_valid([ARM.space.sample(rng) for _ in range(300)])
    assert ch.is_valid(HOME)
    assert 0.5 < ok.mean() < 1.0  # some random configurations fold the arm into itself


def test_obstacles_of_every_type_collide_with_the_hand(checker):
    hand = hand_position()
    far = hand + 2.0
    for prim in (
        Primitive("box", hand, (0.1, 0.1, 0.1), yaw_quat(0.3)),
        Primitive.cylinder(hand, 0.05, 0.1, orientation=(0.3, 0.0, 0.0, 0.95)),
        Primitive.sphere(hand, 0.05),
    ):
        assert not checker(ws_of(prim)).is_valid(HOME), prim.type
        moved = Primitive(prim.type, far, prim.size, prim.orientation)
        assert checker(ws_of(moved)).is_valid(HOME), prim.type


def test_orientation_matters(checker):
    """A thin plate beside the hand: turned by 90 degrees about z it reaches the hand."""
    plate = (0.02, 0.6, 0.3)
    beside = hand_position() + [0.15, 0.0, 0.0]
    assert checker(ws_of(Primitive("box", beside, plate))).is_valid(HOME)
    assert not checker(ws_of(Primitive("box", beside, plate, yaw_quat(math.pi / 2)))).is_valid(HOME)


def test_an_obstacle_on_the_base_blocks_every_configuration(checker):
    """The fixed base and a static obstacle are never paired by Bullet's broadphase; the
    sphere checker tests the base once per workspace."""
    ch = checker(ws_of(Primitive("box", (0.0, 0.0, 0.05), (0.1, 0.1, 0.1))))
    assert not ch.is_valid(HOME) and not ch.states_valid([HOME]).any()
    assert not ch.motion_valid(HOME, HOME) and not ch.motions_valid([HOME], [HOME]).any()


def test_planning_margin_inflates_obstacles(checker):
    near = ws_of(Primitive.sphere(hand_position() + [0.2, 0.0, 0.1], 0.05))  # 10.5 cm from the hand
    assert checker(near, margin=0.0).is_valid(HOME)
    assert not checker(near, margin=0.15).is_valid(HOME)


def _pybullet(ws: Workspace) -> PybulletArmChecker:
    return ARM.make_checker(ws, backend="pybullet")


TWO_SPHERES = ws_of(Primitive.sphere((1, 1, 1), 0.1), Primitive.sphere((1, 1, 2), 0.1))


def test_live_checkers_hold_worlds_of_their_own():
    """Two checkers alive at once never share a pybullet world (no obstacles swapped between
    them); each world holds the arm and its checker's obstacles only."""
    a, b = _pybullet(TWO_SPHERES), _pybullet(ws_of(Primitive.sphere(hand_position(), 0.05)))
    assert a.is_valid(HOME) and not b.is_valid(HOME) and a.is_valid(HOME)
    assert a.world is not b.world and a.world.client != b.world.client
    assert len(a.world.bodies) == 2 and len(b.world.bodies) == 1
    assert a.world.pb.getNumBodies(physicsClientId=a.world.client) == 3


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_a_world_let_go_is_emptied_and_lent_again_without_leaking():
    """A collected checker's world goes to the next checker, its old obstacles removed, its
    collision shapes reused (pybullet never frees one), so thousands of workspaces cost one world."""
    a = _pybullet(TWO_SPHERES)
    assert a.is_valid(HOME)
    world, shapes = a.world, len(a.world.shapes)
    del a
    gc.collect()
    for _ in range(5):
        c = _pybullet(TWO_SPHERES)
        assert c.is_valid(HOME) and c.world is world
        del c
        gc.collect()
    assert world.bodies == [] and world.pb.getNumBodies(physicsClientId=world.client) == 1
    assert len(world.shapes) == shapes


def test_a_checker_never_used_borrows_no_world():
    ch = _pybullet(TWO_SPHERES)
    assert ch._world is None and ch.counts()["configurations_checked"] == 0


def test_checkers_of_two_workspaces_answer_apart_when_interleaved(checker):
    blocked, free = checker(ws_of(Primitive.sphere(hand_position(), 0.05))), checker(EMPTY)
    for _ in range(3):
        assert not blocked.is_valid(HOME) and free.is_valid(HOME)


def test_motion_through_a_wall_is_blocked_and_counted(checker):
    a, b = list(HOME), list(HOME)
    a[0], b[0] = -1.2, 1.2  # swing the arm about its base
    wall = Primitive("box", (0.6, 0.0, 0.5), (0.6, 0.02, 1.0))
    ch = checker(ws_of(wall))
    assert ch.is_valid(a) and ch.is_valid(b) and not ch.motion_valid(a, b)
    assert checker(EMPTY).motion_valid(a, b)
    assert list(ch.motions_valid([a, a], [b, a])) == [False, True]
    counts = ch.counts()
    assert counts["motion_checks"] == 3 and counts["configurations_checked"] >= 3
    assert verify_path(ARM, ws_of(wall), [a, b], a, b) == "collision"
    assert verify_path(ARM, EMPTY, [a, b], a, b) is None


def test_out_of_bounds_states_are_invalid(checker):
    q = list(HOME)
    q[3] = 0.1  # joint 4's upper limit is -0.0698
    ch = checker(EMPTY)
    assert not ch.is_valid(q) and not ch.motion_valid(HOME, q)
    assert not ch.states_valid([q]).any() and not ch.motions_valid([HOME], [q]).any()


@given(st.integers(1, 300))
def test_coarse_to_fine_visits_every_state_once(n):
    order = coarse_to_fine(n)
    assert sorted(order) == list(range(n + 1)) and order[:2] == (0, n)


@settings(deadline=None, max_examples=30)
@given(
    st.sampled_from(["box", "cylinder", "sphere"]),
    st.lists(st.floats(0.05, 1.0), min_size=3, max_size=3),
    st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1),
)
def test_surface_points_lie_on_the_surface(kind, dims, quat):
    size = {"box": dims, "cylinder": [dims[0], dims[0], dims[1]], "sphere": [dims[0]] * 3}[kind]
    p = Primitive(kind, (0.3, -0.2, 0.5), size, quat)
    pts = p.sample_surface(200, np.random.default_rng(1))
    local = (pts - np.array(p.center)) @ p.rotation()  # back into the primitive's frame
    half = np.array(p.size) / 2
    if kind == "box":
        on_face = np.isclose(np.abs(local) / half, 1.0).any(axis=1)
        assert on_face.all() and (np.abs(local) <= half + 1e-9).all()
    elif kind == "cylinder":
        r = np.hypot(local[:, 0], local[:, 1])
        assert (np.isclose(r, p.radius) | np.isclose(np.abs(local[:, 2]), p.height / 2)).all()
        assert (r <= p.radius + 1e-9).all() and (np.abs(local[:, 2]) <= p.height / 2 + 1e-9).all()
    else:
        assert np.allclose(np.linalg.norm(local, axis=1), p.radius)


def test_quat_matrix_is_a_rotation():
    r = quat_matrix([0.1, -0.4, 0.3, 0.8])
    assert np.allclose(r @ r.T, np.eye(3)) and math.isclose(np.linalg.det(r), 1.0)
    assert np.allclose(quat_matrix(yaw_quat(math.pi / 2)) @ [1, 0, 0], [0, 1, 0])


# The clouds drawn by the numpy sampler before it was compiled (5c77dc9's digests: sha256 of the
# float32 cloud, spec.cloud(ws, 200, 0)): Enet's networks were trained on these points, so the
# compiled sampler must draw the same ones, double for double
CLOUD_DIGESTS = {
    "bookshelf_small_panda/0001": "3956ecd26b12e5b8",
    "bookshelf_small_panda/0002": "a3e1b0cb31cefd37",
    "box_panda/0001": "32c01fc577ed8ad2",
    "box_panda/0002": "ba655bc4360fe842",
    "table_pick_panda/0001": "e3c27e36f4aadcfd",
    "table_pick_panda/0002": "66998c192b749506",
    "mixed": "9b673bf3819e40bd",
}


def test_the_compiled_cloud_draws_the_points_numpy_drew(mbm_dir):
    """Known answers: MotionBenchMaker's scenes (boxes, cylinders) and a rotated box, cylinder
    and sphere, as the numpy sampler drew them."""
    import hashlib

    def digest(a):
        return hashlib.sha256(np.ascontiguousarray(a, np.float32).tobytes()).hexdigest()[:16]

    spec = get_spec("panda_mbm")
    got = {ws.id: digest(spec.cloud(ws, 200, 0)) for ws in load_mbm(mbm_dir, spec).workspaces}
    prims = [
        Primitive("box", (0.1, -0.2, 0.3), (0.2, 0.5, 0.05), (0.1, 0.2, 0.3, 0.9)),
        Primitive.cylinder((0.4, 0.1, 0.2), 0.05, 0.3, (0.3, -0.1, 0.2, 0.9)),
        Primitive.sphere((-0.3, 0.2, 0.6), 0.07),
        Primitive("box", (0.0, 0.0, -0.1), (2.0, 2.0, 0.02)),
    ]
    got["mixed"] = digest(surface_cloud(prims, 3001, np.random.default_rng(11)))
    assert got == CLOUD_DIGESTS


def test_cloud_has_a_fixed_size_and_shares_points_by_area():
    big, small = Primitive("box", (0, 0, 0), (1, 1, 1)), Primitive("box", (5, 0, 0), (0.1, 0.1, 0.1))
    pts = surface_cloud([big, small], 1000, np.random.default_rng(0))
    assert pts.shape == (1000, 3)
    assert 0 < (pts[:, 0] > 4).sum() < 30  # the small box has 1% of the area
    ws = ARM.generator.make(3, "seen")
    assert ARM.cloud(ws, 200, 0).shape == (2000, 3)
    assert np.array_equal(ARM.cloud(ws, 200, 0), ARM.cloud(ws, 200, 0))


def test_generated_workspaces_are_seeded_and_varied():
    a, b = ARM.generator.make(5, "seen", 0), ARM.generator.make(5, "seen", 0)
    assert a.primitives == b.primitives
    assert a.primitives != ARM.generator.make(6, "seen", 0).primitives
    assert a.primitives != ARM.generator.make(5, "seen", 1).primitives
    for i in range(20):
        ws = ARM.generator.make(i, "seen")
        assert 6 <= len(ws.primitives) <= 40
        # nothing but the table near the base's axis
        for p in ws.primitives[1:]:
            assert math.hypot(p.center[0], p.center[1]) > 0.3 - 1e-9


def test_problems_at_2_round_trip(tmp_path, mbm_dir):
    ts = load_mbm(mbm_dir, ARM)
    dump_problems(tmp_path / "p.json", ts)
    doc = json.loads((tmp_path / "p.json").read_text())
    assert doc["format"] == FORMAT_2
    back = load_problems(tmp_path / "p.json", ARM)
    assert [q.id for q in back.queries] == [q.id for q in ts.queries]
    assert [w.primitives for w in back.workspaces] == [w.primitives for w in ts.workspaces]
    ws = back.workspaces[0]
    assert Workspace.from_json(ws.id, ws.split, ws.obstacles_json(), 3).primitives == ws.primitives


@pytest.mark.parametrize(
    "obstacle,needle",
    [
        ({"type": "cone", "center": [0, 0, 0], "size": [1, 1, 1]}, 'type is "cone"'),
        ({"type": "cylinder", "center": [0, 0, 0], "size": [1, 2, 1]}, "cylinder's size"),
        ({"type": "sphere", "center": [0, 0, 0], "size": [1, 1, 2]}, "sphere's size"),
        ({"center": [0, 0, 0], "size": [1, 1, 1], "orientation": [0, 0, 0, 0]}, "zero quaternion"),
        ({"center": [0, 0, 0], "size": [1, 1, 1], "orientation": [0, 0, 1]}, "orientation has 3 numbers"),
    ],
)
def test_bad_posed_obstacles(tmp_path, obstacle, needle):
    doc = {
        "format": FORMAT_2,
        "env": "arm7",
        "workspaces": [{"id": "w", "obstacles": [obstacle], "queries": [{"start": HOME, "goal": HOME}]}],
    }
    (tmp_path / "p.json").write_text(json.dumps(doc))
    with pytest.raises(ProblemFileError) as e:
        load_problems(tmp_path / "p.json", ARM)
    assert needle in str(e.value) and "obstacle #0" in str(e.value) and "\n" not in str(e.value)


def test_at_1_files_refuse_posed_obstacles(tmp_path):
    """An @1 reader would take a sphere for an axis-aligned box: refused, not reinterpreted."""
    doc = {
        "format": "mpnet-bench/problems@1",
        "env": "arm7",
        "workspaces": [
            {
                "id": "w",
                "obstacles": [{"type": "sphere", "center": [1, 1, 1], "size": [0.2, 0.2, 0.2]}],
                "queries": [{"start": HOME, "goal": HOME}],
            }
        ],
    }
    (tmp_path / "p.json").write_text(json.dumps(doc))
    with pytest.raises(ProblemFileError, match="need format 'mpnet-bench/problems@2'"):
        load_problems(tmp_path / "p.json", ARM)


def test_posed_obstacles_need_a_3d_env(tmp_path):
    doc = {
        "format": FORMAT_2,
        "env": "s2d",
        "workspaces": [
            {
                "id": "w",
                "obstacles": [{"type": "box", "center": [0, 0], "size": [1, 1]}],
                "queries": [{"start": [5, 5], "goal": [-5, -5]}],
            }
        ],
    }
    (tmp_path / "p.json").write_text(json.dumps(doc))
    with pytest.raises(ProblemFileError, match="need an env whose checker handles them"):
        load_problems(tmp_path / "p.json", get_spec("s2d"))
    doc["env"] = "c3d"  # 3D, but its point checker knows only axis-aligned boxes
    doc["workspaces"][0]["obstacles"] = [{"type": "sphere", "center": [0, 0, 0], "size": [4, 4, 4]}]
    doc["workspaces"][0]["queries"] = [{"start": [5, 5, 5], "goal": [-5, -5, -5]}]
    (tmp_path / "p.json").write_text(json.dumps(doc))
    with pytest.raises(ProblemFileError, match="need an env whose checker handles them"):
        load_problems(tmp_path / "p.json", get_spec("c3d"))


def test_mbm_problems_load_with_their_names(mbm_dir):
    ts = load_mbm(mbm_dir, ARM)
    assert [q.id for q in ts.queries][:2] == ["bookshelf_small_panda/0001", "bookshelf_small_panda/0002"]
    assert len(ts.queries) == 6 and all(q.workspace_id == q.id for q in ts.queries)


def test_mbm_problems_per_set_takes_each_sets_first(mbm_dir):
    """problems_per_set=N: the first N problems of every set by number, not the first N overall."""
    ts = load_mbm(mbm_dir, ARM, per_set=1)
    assert [q.id for q in ts.queries] == ["bookshelf_small_panda/0001", "box_panda/0001", "table_pick_panda/0001"]
    assert [w.id for w in ts.workspaces] == [q.id for q in ts.queries]
    assert len(load_mbm(mbm_dir / "box_panda", ARM, per_set=1).queries) == 1
    assert len(load_mbm(mbm_dir, ARM, per_set=5).queries) == 6
    box = next(w for w in ts.workspaces if w.id == "box_panda/0001")
    assert {p.type for p in box.primitives} == {"box", "cylinder"}
    one = load_mbm(mbm_dir / "box_panda", ARM)
    assert [q.id for q in one.queries] == ["box_panda/0001", "box_panda/0002"]
    single = load_mbm(mbm_dir / "box_panda" / "scene0002.yaml", ARM)
    assert [q.id for q in single.queries] == ["box_panda/0002"]
    assert np.allclose(single.queries[0].start, HOME, atol=1e-3)


def test_mbm_errors_are_one_line(tmp_path, mbm_dir):
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "scene0001.yaml").write_text("world: [unclosed")
    (tmp_path / "s" / "request0001.yaml").write_text((mbm_dir / "box_panda" / "request0001.yaml").read_text())
    with pytest.raises(ProblemFileError) as e:
        load_mbm(tmp_path / "s", ARM)
    assert "scene0001.yaml: cannot read it as YAML" in str(e.value) and "\n" not in str(e.value)
    (tmp_path / "s" / "request0001.yaml").write_text("start_state: {}")
    with pytest.raises(ProblemFileError, match="request0001.yaml: not a MoveIt request"):
        load_mbm(tmp_path / "s", ARM)
    with pytest.raises(ProblemFileError, match="need an env whose robot is an arm model, not c3d"):
        load_mbm(mbm_dir, get_spec("c3d"))
    (tmp_path / "empty").mkdir()
    with pytest.raises(ProblemFileError, match="no MotionBenchMaker"):
        load_mbm(tmp_path / "empty", ARM)
    with pytest.raises(ProblemFileError, match="no such file or folder"):
        load_mbm(tmp_path / "typo.yaml", ARM)


def _scene(objects: list) -> str:
    return json.dumps({"world": {"collision_objects": objects}})  # JSON is YAML


BOX = {"type": "box", "dimensions": [0.1, 0.2, 0.3]}
AT = {"position": [0.5, 0.0, 0.2], "orientation": [0, 0, 0, 1]}


@pytest.mark.parametrize(
    "objects,needle",
    [
        ([{"id": "a", "primitives": [{"type": "box", "dimensions": [0.1, 0.2]}], "primitive_poses": [AT]}], "3 finite"),
        ([{"id": "a", "primitives": [{"type": "sphere", "dimensions": [-0.1]}], "primitive_poses": [AT]}], "positive"),
        ([{"id": "a", "primitives": [{"type": "cone", "dimensions": [1]}], "primitive_poses": [AT]}], "'cone'"),
        ([{"id": "a", "primitives": [BOX], "primitive_poses": []}], "as many primitive_poses"),
        (
            [{"id": "a", "primitives": [BOX], "primitive_poses": [{"position": [0, 0, 0], "orientation": [0] * 4}]}],
            "zero quaternion",
        ),
        ([{"id": "a", "primitives": [BOX], "primitive_poses": [AT], "pose": {"position": [0, 0]}}], "pose position"),
        ([{"id": "a", "meshes": [{}]}], "meshes"),
        ("nope", "no world.collision_objects"),
    ],
)
def test_mbm_scene_errors_name_the_object(tmp_path, mbm_dir, objects, needle):
    (tmp_path / "scene0001.yaml").write_text(_scene(objects))
    (tmp_path / "request0001.yaml").write_text((mbm_dir / "box_panda" / "request0001.yaml").read_text())
    with pytest.raises(ProblemFileError) as e:
        load_mbm(tmp_path, ARM)
    assert needle in str(e.value) and "scene0001.yaml" in str(e.value) and "\n" not in str(e.value)


def test_mbm_object_pose_composes_with_primitive_poses(tmp_path, mbm_dir):
    """MoveIt places an object's primitives relative to the object's own pose."""
    turn = [0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)]  # 90 degrees about z
    obj = {
        "id": "a",
        "pose": {
            "position": {"x": 1.0, "y": 0.0, "z": 0.5},
            "orientation": {"x": 0, "y": 0, "z": turn[2], "w": turn[3]},
        },
        "primitives": [BOX],
        "primitive_poses": [{"position": [0.2, 0.0, 0.0], "orientation": turn}],
    }
    (tmp_path / "scene0001.yaml").write_text(_scene([obj]))
    (tmp_path / "request0001.yaml").write_text((mbm_dir / "box_panda" / "request0001.yaml").read_text())
    (p,) = load_mbm(tmp_path, ARM).workspaces[0].primitives
    assert np.allclose(p.center, [1.0, 0.2, 0.5])
    assert np.allclose(np.abs(p.orientation), [0, 0, 1, 0], atol=1e-9)  # 180 degrees about z


def _tar(members: dict[str, bytes], mode: str) -> bytes:
    import io
    import tarfile

    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode=mode) as t:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            t.addfile(info, io.BytesIO(data))
    return buf.getvalue()


def test_fetch_mbm_unpacks_the_panda_problems_of_an_sdist(tmp_path, mbm_dir, capsys, monkeypatch):
    from harness import fetch_mbm
    from harness.fetch_mbm import main

    panda = [a for a in fetch_mbm.ARCHIVES["problems"] if "panda" in a["member"]]
    monkeypatch.setitem(fetch_mbm.ARCHIVES, "problems", panda)  # the other robots' archives: test_robot_files
    pair = {
        f"problems/box_panda/{n}0001.yaml": (mbm_dir / "box_panda" / f"{n}0001.yaml").read_bytes()
        for n in ("scene", "request")
    }
    sdist = _tar({"vamp_planner-0.6.4/resources/panda/problems.tar.bz2": _tar(pair, "w:bz2")}, "w:gz")
    (tmp_path / "v.tar.gz").write_bytes(sdist)
    assert main([str(tmp_path / "out"), "--sdist", str(tmp_path / "v.tar.gz")]) == 0
    assert "box_panda: 1 problems" in capsys.readouterr().out
    assert [q.id for q in load_mbm(tmp_path / "out" / "problems", ARM).queries] == ["box_panda/0001"]
    (tmp_path / "bad.tar.gz").write_bytes(_tar({"x/README": b"no problems"}, "w:gz"))
    assert main([str(tmp_path / "out2"), "--sdist", str(tmp_path / "bad.tar.gz")]) == 1
    assert "has no resources/panda/problems.tar.bz2" in capsys.readouterr().err
