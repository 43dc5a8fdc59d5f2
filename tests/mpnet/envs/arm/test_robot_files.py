"""A robot of one's own is files: a URDF with STL meshes and box/sphere primitives, a description
in a robot folder of the user's (MPNET_BENCH_ROBOTS), its sphere set made by harness.spherize,
an env built from a definition; and harness.fetch_mbm installing such a robot from a source
distribution. The robot here is a toy (two joints), small enough to spherize in seconds."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from mpnet.envs.arm import model as arm_model
from mpnet.envs.arm.model import ArmModelError, load_arm_model, read_urdf, robot_dirs, user_robot_dir
from mpnet.envs.arm.spherize import read_stl_vertices, shape_points
from mpnet.envs.shapes import Primitive
from mpnet.envs.workspace import Workspace
from tests.mpnet.envs.arm.test_arm import _tar  # an sdist's nested archives, in memory

CUBE = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (0.0, 0.3)])
FACES = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6), (0, 2, 6),
         (0, 6, 4), (1, 5, 7), (1, 7, 3)]  # fmt: skip

URDF = """<?xml version="1.0"?>
<robot name="toy">
  <link name="root"><collision><geometry><box size="0.2 0.2 0.1"/></geometry></collision>
    <visual><geometry><mesh filename="package://meshes/missing.dae"/></geometry></visual></link>
  <link name="arm"><collision><origin xyz="0 0 0.05"/><geometry><mesh filename="package://meshes/arm.stl"/></geometry>
    </collision></link>
  <link name="tip"><collision><origin xyz="0 0 0.2"/><geometry><sphere radius="0.04"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="root"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="arm"/><child link="tip"/><origin xyz="0 0 0.4"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>
"""
DESCRIPTION = """name: toy
urdf: toy/toy.urdf
joints: [j1, j2]
end_effector: tip
spheres: toy_spheres.json
install: installed by the test
spherize: {spacing: 0.008, pad: 0.01, reach_others: 0.01}
allowed: [[root, tip]]
"""


def binary_stl(vertices: np.ndarray, faces) -> bytes:
    rec = np.zeros(len(faces), [("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    rec["corners"] = vertices[np.array(faces)]
    return b"toy".ljust(80, b" ") + len(faces).to_bytes(4, "little") + rec.tobytes()


def ascii_stl(vertices: np.ndarray, faces) -> bytes:
    rows = ["solid toy"]
    for f in faces:
        rows += ["facet normal 0 0 0", "outer loop", *(f"vertex {x} {y} {z}" for x, y, z in vertices[list(f)])]
        rows += ["endloop", "endfacet"]
    return ("\n".join([*rows, "endsolid toy"]) + "\n").encode()


def robot_files(visual: bool = True) -> dict[str, bytes]:
    """The toy's files as a robot folder holds them (relative paths); visual: with the <visual>
    element naming a mesh that is not there (pybullet refuses such a URDF; fetch_mbm strips it)."""
    urdf = URDF if visual else re.sub(r"<visual>.*?</visual>", "", URDF, flags=re.S)
    return {"toy/toy.urdf": urdf.encode(), "toy/meshes/arm.stl": binary_stl(CUBE, FACES)}


@pytest.fixture
def robots(tmp_path, monkeypatch):
    """An empty robot folder of the user's, and the models' caches (load_arm_model's, sphere_model's)
    cleared before and after: each test's toy is its own."""
    from mpnet.envs.checkers.spheres import sphere_model

    folder = tmp_path / "robots"
    monkeypatch.setenv("MPNET_BENCH_ROBOTS", str(folder))
    load_arm_model.cache_clear()
    sphere_model.cache_clear()
    yield folder
    load_arm_model.cache_clear()
    sphere_model.cache_clear()


def install(folder, files: dict[str, bytes]) -> None:
    for rel, data in files.items():
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_bytes(data)


def test_stl_binary_and_ascii_read_the_same_corners(tmp_path):
    (tmp_path / "b.stl").write_bytes(binary_stl(CUBE, FACES))
    (tmp_path / "a.STL").write_bytes(ascii_stl(CUBE, FACES))
    b, a = read_stl_vertices(tmp_path / "b.stl"), read_stl_vertices(tmp_path / "a.STL")
    assert b.shape == (36, 3) and np.allclose(a, b, atol=1e-7)
    assert {tuple(v) for v in np.round(b, 6)} == {tuple(v) for v in np.round(CUBE, 6)}
    (tmp_path / "x.stl").write_bytes(b"not a mesh")
    with pytest.raises(ArmModelError, match="x.stl: neither a binary nor an ASCII STL"):
        read_stl_vertices(tmp_path / "x.stl")


def test_urdf_primitives_and_meshes_are_collision_shapes(tmp_path):
    install(tmp_path, robot_files())
    kin = read_urdf(tmp_path / "toy" / "toy.urdf", ("j1", "j2"), {})
    shapes = {s.link: s for s in kin.shapes}
    assert [shapes[k].geometry for k in ("root", "arm", "tip")] == ["box", "mesh", "sphere"]
    assert shapes["root"].size == (0.2, 0.2, 0.1) and shapes["tip"].size == (0.04,)
    corners = shape_points(shapes["root"])
    assert corners.shape == (8, 3) and np.allclose(np.abs(corners), [0.1, 0.1, 0.05])
    assert np.allclose(shape_points(shapes["arm"]).min(axis=0), [-0.05, -0.05, 0.05])  # the origin applied
    bad = URDF.replace('<sphere radius="0.04"/>', '<cylinder radius="0.04" length="0.1"/>')
    (tmp_path / "bad.urdf").write_text(bad)
    with pytest.raises(ArmModelError, match="link 'tip'.s collision geometry 'cylinder' is not supported"):
        read_urdf(tmp_path / "bad.urdf", ("j1", "j2"), {})
    two = URDF.replace("</collision></link>\n  <joint", "</collision><collision><geometry><box size='1 1 1'/>"
                       "</geometry></collision></link>\n  <joint", 1)  # fmt: skip
    (tmp_path / "two.urdf").write_text(two)
    with pytest.raises(ArmModelError, match="2 <collision> elements; one is supported"):
        read_urdf(tmp_path / "two.urdf", ("j1", "j2"), {})


def test_pybullet_refusing_a_urdf_is_named(robots):
    from mpnet.envs.checkers.pybullet_arm import ArmWorld

    install(robots, {**robot_files(visual=True), "toy.yaml": DESCRIPTION.encode()})
    with pytest.raises(ArmModelError, match="toy.urdf: pybullet cannot load it .every mesh it names, <visual> ones"):
        ArmWorld(load_arm_model("toy"))


@pytest.mark.slow  # spherizes the toy, compiles its env's kernels (cached: the Panda's types)
def test_a_robot_of_ones_own_is_files_in_a_robot_folder(robots, capsys):
    """Description, URDF and meshes in the user's folder; harness.spherize writes the set beside
    them; the sphere checker then agrees with pybullet on the toy's configurations."""
    from harness.compile_kernels import compile_env
    from harness.spherize import main as spherize_main
    from mpnet.envs.specs import build

    with pytest.raises(ArmModelError, match="unknown arm model 'toy'"):
        load_arm_model("toy")
    install(robots, {**robot_files(visual=False), "toy.yaml": DESCRIPTION.encode()})
    assert robot_dirs()[1] == robots and user_robot_dir() == robots
    model = load_arm_model("toy")
    with pytest.raises(ArmModelError, match="no sphere set toy_spheres.json yet .python -m harness.spherize toy"):
        model.digest()
    assert spherize_main(["toy"]) == 0
    assert "robots/toy_spheres.json" in capsys.readouterr().out
    doc = json.loads((robots / "toy_spheres.json").read_text())
    assert (doc["spacing"], doc["pad"]) == (0.008, 0.01)  # the description's settings
    assert doc["links"]["tip"] == [[0.0, 0.0, 0.2, 0.04]]  # a sphere primitive: itself
    assert len(model.digest()) == 16
    robot = {"class": "mpnet.envs.robots.ArmRobot", "args": ["toy"]}
    steps = {"validation_step": 0.002, "motion_step": 0.02, "planning_margin": 0.0}
    spec = build("toy_env", {"robot": robot, "workspace_dim": 3, "generator": None, **steps})
    assert spec.generator is None and spec.state_dim == 2
    wall = Workspace(
        "w", "file", np.zeros((0, 3)), np.zeros((0, 3)), (Primitive("box", (0.2, 0.0, 0.5), (0.15, 2.0, 0.4)),)
    )
    spheres, judge = spec.make_checker(wall), spec.judge_checker(wall)
    qs = np.random.default_rng(0).uniform([-3, -2], [3, 2], (300, 2))
    free = [spheres.is_valid(q) for q in qs.tolist()]
    truth = [judge.is_valid(q) for q in qs.tolist()]
    assert 30 < sum(free) < 270  # the wall blocks some of them
    assert not any(f and not t for f, t in zip(free, truth))  # spheres free => meshes free
    compile_env(spec, [])  # harness.compile_kernels on an env of problem files only: checks and RRT-Connect
    assert sum(t and not f for f, t in zip(free, truth)) <= 0.1 * len(qs)  # and not much more cautious


@pytest.mark.slow  # spherizes the toy twice
def test_fetch_mbm_installs_a_robot_without_visuals_and_spherizes_it(robots, tmp_path, mbm_dir, monkeypatch, capsys):
    import harness.fetch_mbm as fetch_mbm

    monkeypatch.setitem(fetch_mbm.ARCHIVES, "problems", [{"member": "resources/toy/problems.tar.bz2", "dest": "."}])
    robot = {"model": "toy", "folder": "resources/toy", "urdf": "toy.urdf", "files": ["meshes/"], "dest": "toy"}
    monkeypatch.setitem(fetch_mbm.ARCHIVES, "robots", [robot])
    install(robots, {"toy.yaml": DESCRIPTION.encode()})  # the description ships; the URDF and meshes do not
    pair = {f"problems/box_panda/{n}0001.yaml": (mbm_dir / "box_panda" / f"{n}0001.yaml").read_bytes()
            for n in ("scene", "request")}  # fmt: skip
    files = {f"v/resources/toy/{k.removeprefix('toy/')}": v for k, v in robot_files().items()}
    sdist = _tar({"v/resources/toy/problems.tar.bz2": _tar(pair, "w:bz2"), **files}, "w:gz")
    (tmp_path / "v.tar.gz").write_bytes(sdist)
    assert fetch_mbm.main([str(tmp_path / "out"), "--sdist", str(tmp_path / "v.tar.gz"), "--robot", "toy"]) == 0
    out = capsys.readouterr().out
    assert "box_panda: 1 problems" in out and "toy_spheres.json: " in out
    urdf = (robots / "toy" / "toy.urdf").read_text()
    assert "<visual" not in urdf and "<collision>" in urdf and (robots / "toy" / "meshes" / "arm.stl").is_file()
    assert "sha256" in (robots / "toy" / "README.txt").read_text()
    assert fetch_mbm.main([str(tmp_path / "out"), "--sdist", str(tmp_path / "v.tar.gz"), "--robot", "toy"]) == 0
    assert "toy_spheres.json: kept" in capsys.readouterr().out  # made from these meshes already
    files["v/resources/toy/meshes/arm.stl"] = ascii_stl(CUBE * 1.5, FACES)  # another mesh: the set is remade
    (tmp_path / "v.tar.gz").write_bytes(
        _tar({"v/resources/toy/problems.tar.bz2": _tar(pair, "w:bz2"), **files}, "w:gz")
    )
    load_arm_model.cache_clear()
    assert fetch_mbm.main([str(tmp_path / "out"), "--sdist", str(tmp_path / "v.tar.gz"), "--robot", "toy"]) == 0
    assert "toy_spheres.json: kept" not in capsys.readouterr().out
    # a description whose settings changed (a finer covering shipped): the set is remade with them
    install(robots, {"toy.yaml": DESCRIPTION.replace("pad: 0.01", "pad: 0.012").encode()})
    load_arm_model.cache_clear()
    assert fetch_mbm.main([str(tmp_path / "out"), "--sdist", str(tmp_path / "v.tar.gz"), "--robot", "toy"]) == 0
    assert "toy_spheres.json: kept" not in capsys.readouterr().out
    assert json.loads((robots / "toy_spheres.json").read_text())["pad"] == 0.012


def test_problems_for_another_robot_are_refused_or_passed_over(tmp_path, mbm_dir):
    from mpnet.envs.mbm.files import load_mbm
    from mpnet.envs.specs import get_spec
    from mpnet.problems import ProblemFileError

    arm = get_spec("arm7")
    for robot, family in (("panda", "box_panda"), ("ur5_robotiq85", "box_ur5")):
        (tmp_path / "all" / family).mkdir(parents=True)
        for n in ("scene", "request"):
            text = (mbm_dir / "box_panda" / f"{n}0001.yaml").read_text()
            (tmp_path / "all" / family / f"{n}0001.yaml").write_text(
                text.replace("robot_model_name: panda", f"robot_model_name: {robot}")
            )
    assert [q.id for q in load_mbm(tmp_path / "all", arm).queries] == ["box_panda/0001"]  # the Panda's folders only
    with pytest.raises(ProblemFileError, match="scene0001.yaml: a scene for robot ur5_robotiq85, not panda"):
        load_mbm(tmp_path / "all" / "box_ur5", arm)
    (tmp_path / "all" / "box_panda" / "scene0001.yaml").unlink()
    with pytest.raises(ProblemFileError, match="no problems for robot panda here .its scenes are for ur5_robotiq85"):
        load_mbm(tmp_path / "all", arm)


def test_an_env_without_a_generator_says_it_plans_problem_files_only():
    from mpnet.envs.scenes.generators import make_workspace
    from mpnet.envs.specs import build

    spec = build("files_only", {"robot": {"class": "mpnet.envs.robots.ArmRobot", "args": ["panda"]},
                                "workspace_dim": 3, "generator": None})  # fmt: skip
    with pytest.raises(ValueError, match="env files_only has no workspace generator: it plans problem files only"):
        make_workspace(spec, 0, "seen")


def test_robot_folders_are_searched_in_order(tmp_path, monkeypatch):
    a, b = tmp_path / "a", tmp_path / "b"
    monkeypatch.setenv("MPNET_BENCH_ROBOTS", f"{a}:{b}")
    assert robot_dirs()[1:3] == [a, b] and user_robot_dir() == a
    b.mkdir()
    (b / "x.yaml").write_text("b")
    assert arm_model.robot_file("x.yaml") == b / "x.yaml" and arm_model.robot_file("nothing.yaml") is None
    assert arm_model.robot_file("panda.yaml").parent == robot_dirs()[0]  # the package's first


@pytest.mark.slow  # spherizes the toy
def test_links_no_joint_moves_are_tested_against_a_workspace_once(robots):
    """A robot standing on a link fixed to the root (the UR5's base on its offset link): that link
    is one the kernels skip (SphereModel.first) and the checker tests once a workspace: touching
    it blocks every state; elsewhere the checker still agrees with pybullet's meshes."""
    from harness.spherize import main as spherize_main
    from mpnet.envs.checkers.spheres import SphereModel
    from mpnet.envs.specs import build

    fixed = '<robot name="toy">\n  <link name="world"/>\n  <joint name="fix" type="fixed"><parent link="world"/>'
    fixed += '<child link="root"/><origin xyz="0 0 0.1"/></joint>'
    files = robot_files(visual=False)
    files["toy/toy.urdf"] = files["toy/toy.urdf"].decode().replace('<robot name="toy">', fixed).encode()
    install(robots, {**files, "toy.yaml": DESCRIPTION.encode()})
    assert spherize_main(["toy"]) == 0
    model = SphereModel(load_arm_model("toy"))
    assert model.first == 1 and model.links[0] == "root" and model.link_frame[0] != 0  # not the root frame
    robot = {"class": "mpnet.envs.robots.ArmRobot", "args": ["toy"]}
    steps = {"validation_step": 0.002, "motion_step": 0.02, "planning_margin": 0.0}
    spec = build("toy_env", {"robot": robot, "workspace_dim": 3, "generator": None, **steps})
    qs = np.random.default_rng(1).uniform([-3, -2], [3, 2], (200, 2))

    def workspace(centre, size):
        return Workspace("w", "file", np.zeros((0, 3)), np.zeros((0, 3)), (Primitive("box", centre, size),))

    on_base = spec.make_checker(workspace((0.0, 0.3, 0.1), (0.1, 0.5, 0.05)))  # touches the root's box only
    assert on_base.base_blocked and not any(on_base.is_valid(q) for q in qs.tolist())
    wall = workspace((0.2, 0.0, 0.6), (0.15, 2.0, 0.4))
    spheres, judge = spec.make_checker(wall), spec.judge_checker(wall)
    free = [spheres.is_valid(q) for q in qs.tolist()]
    truth = [judge.is_valid(q) for q in qs.tolist()]
    assert not spheres.base_blocked and 20 < sum(free) < 180
    assert not any(f and not t for f, t in zip(free, truth))


@pytest.mark.parametrize("tip", ['<box size="0.06 0.06 0.06"/>', '<sphere radius="0.04"/>'])
def test_an_exact_pair_is_tested_on_its_hulls(robots, tip):
    """A description's exact_pairs: the pair's convex hulls decide (hull_kernels), never
    calling free a state or a motion the judge's meshes find colliding, and refusing fewer
    states near the contact than the pair's spheres (padded 1 cm here) do; a sphere's shape is its
    centre grown by its radius."""
    from harness.spherize import main as spherize_main
    from mpnet.envs.checkers.spheres import sphere_model
    from mpnet.envs.specs import build

    urdf = URDF.replace('<origin xyz="0 0 0.4"/><axis xyz="0 1 0"/>', '<origin xyz="0 0 0.15"/><axis xyz="0 1 0"/>')
    urdf = urdf.replace('<limit lower="-2" upper="2"', '<limit lower="-3" upper="3"')
    urdf = urdf.replace('<geometry><sphere radius="0.04"/>', f"<geometry>{tip}")
    files = {
        **robot_files(visual=False),
        "toy/toy.urdf": re.sub(r"<visual>.*?</visual>", "", urdf, flags=re.S).encode(),
    }
    spheres_only = DESCRIPTION.replace("allowed: [[root, tip]]\n", "")
    install(robots, {**files, "toy.yaml": (spheres_only + "exact_pairs: [[tip, root]]\n").encode()})
    assert spherize_main(["toy"]) == 0
    robot = {"class": "mpnet.envs.robots.ArmRobot", "args": ["toy"]}
    steps = {"validation_step": 0.002, "motion_step": 0.02, "planning_margin": 0.0}
    spec = build("toy_env", {"robot": robot, "workspace_dim": 3, "generator": None, **steps})
    empty = Workspace("w", "file", np.zeros((0, 3)), np.zeros((0, 3)), ())
    exact, judge = spec.make_checker(empty), spec.judge_checker(empty)
    rng = np.random.default_rng(2)
    qs = np.column_stack([rng.uniform(-3, 3, 400), rng.uniform(2.0, 2.6, 400)])  # the tip near the root's box
    free, truth = exact.states_valid(qs), judge.states_valid(qs)
    assert 40 < truth.sum() < 360 and not (free & ~truth).any()
    a, b = qs[free][:-1], qs[free][1:]
    for x, y in zip(a[exact.motions_valid(a, b)], b[exact.motions_valid(a, b)]):
        assert judge.states_valid(x + np.linspace(0, 1, 200)[:, None] * (y - x)).all()
    # the same toy without the exact pair: its spheres refuse more of the judge's free states
    (robots / "toy.yaml").write_text(spheres_only, encoding="utf-8")
    load_arm_model.cache_clear()
    sphere_model.cache_clear()
    cautious = build("toy_env2", {"robot": robot, "workspace_dim": 3, "generator": None, **steps}).make_checker(empty)
    assert cautious.states_valid(qs).sum() < free.sum()


def test_a_rewritten_robot_file_is_not_judged_by_the_old_world(robots):
    """pybullet worlds are kept for reuse by what they were loaded from: a URDF rewritten under
    the same name (a sphere tip for a box one) gets a world of its own, not the old one (before,
    the pool was keyed by the model's fields alone and the old tip went on judging)."""
    from mpnet.envs.checkers.pybullet_arm import lent_world

    box = URDF.replace('<geometry><sphere radius="0.04"/>', '<geometry><box size="0.06 0.06 0.06"/>')
    files = robot_files(visual=False)
    install(robots, {**files, "toy/toy.urdf": re.sub(r"<visual>.*?</visual>", "", box, flags=re.S).encode()})
    install(robots, {"toy.yaml": DESCRIPTION.encode()})
    with lent_world(load_arm_model("toy")) as first:
        pass
    install(robots, files)  # the sphere tip again, same name, same description
    load_arm_model.cache_clear()
    with lent_world(load_arm_model("toy")) as second:
        assert second is not first
        tip = next(i for i, name in second.link_names.items() if name == "tip")
        shape = second.pb.getCollisionShapeData(second.robot, tip, physicsClientId=second.client)[0]
        assert shape[2] == second.pb.GEOM_SPHERE
