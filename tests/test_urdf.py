"""The URDF of the robot (navstack.urdf, ``Chain.to_urdf``, ``navstack urdf``) read back by PyBullet and
Pinocchio: the same frames as ``frames(q)``, the same limits, masses, inertias and collision geometry as
the PyBullet body navstack builds itself."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from navstack.jpl import jpl_serpentine
from navstack.sim import body as sim_body
from navstack.sim._bullet import direct_client
from navstack.sim._bullet import pybullet as p
from navstack.sim.body import RobotBody
from navstack.urdf import UrdfOptions, chain_to_urdf

N_CONFIGS = 100
FLAGS = p.URDF_USE_INERTIA_FROM_FILE | p.URDF_USE_IMPLICIT_CYLINDER


@pytest.fixture(scope="module")
def chain():
    return jpl_serpentine()


@pytest.fixture(scope="module")
def urdf_file(chain, tmp_path_factory):
    path = tmp_path_factory.mktemp("urdf") / "jpl.urdf"
    path.write_text(chain.to_urdf())
    return path


@pytest.fixture(scope="module")
def configs(chain):
    rng = np.random.default_rng(20260113)
    return rng.uniform(chain.lower, chain.upper, size=(N_CONFIGS, chain.n))


@pytest.fixture()
def bullet(chain, urdf_file):
    """A DIRECT client with the URDF body and navstack's own body, both at the origin."""
    client = direct_client()
    urdf_id = client.loadURDF(str(urdf_file), useFixedBase=True, flags=FLAGS)
    own = RobotBody.build(client, chain)
    yield client, urdf_id, own
    client.disconnect()


def test_to_urdf_is_the_module_function_and_valid_xml(chain):
    text = chain.to_urdf()
    assert text == chain_to_urdf(chain)
    root = ET.fromstring(text)
    assert root.tag == "robot" and root.get("name") == "jpl-serpentine"
    joints = root.findall("joint")
    assert [j.get("type") for j in joints] == ["prismatic"] + ["revolute"] * 19 + ["fixed"]
    assert len(root.findall("link")) == 22
    # capsule = cylinder + two spheres, in both collision and visual, on every link with a segment
    for link in root.findall("link"):
        kinds = sorted(c.find("geometry")[0].tag for c in link.findall("collision"))
        assert kinds in ([], ["cylinder", "sphere", "sphere"])


def test_pinocchio_frames_match_frames_q(chain, urdf_file, configs):
    pin = pytest.importorskip("pinocchio")
    model = pin.buildModelFromUrdf(str(urdf_file))
    data = model.createData()
    assert model.nq == chain.n
    assert [model.names[i] for i in range(1, model.njoints)] == [f"joint{k}" for k in range(1, 21)]
    np.testing.assert_array_equal(model.lowerPositionLimit, chain.lower)
    np.testing.assert_array_equal(model.upperPositionLimit, chain.upper)
    ids = [model.getFrameId(f"dh{k}") for k in range(chain.n_frames)]
    worst = 0.0
    for q in configs:
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        F = chain.frames(q)
        for k, fid in enumerate(ids):
            M = data.oMf[fid]
            worst = max(worst, float(np.abs(M.translation - F[k, :3, 3]).max()),
                        float(np.abs(M.rotation - F[k, :3, :3]).max()))
    print(f"pinocchio URDF vs frames(q), {N_CONFIGS} configurations: max error {worst:.2e}")
    assert worst < 1e-9


def test_pinocchio_reads_the_collision_geometry(chain, urdf_file):
    pin = pytest.importorskip("pinocchio")
    model = pin.buildModelFromUrdf(str(urdf_file))
    geom = pin.buildGeomFromUrdf(model, str(urdf_file), pin.GeometryType.COLLISION)
    capsule_links = sum(1 for k in range(1, len(chain.alpha)) if np.linalg.norm(_segment(chain, k)) > 1e-9)
    assert geom.ngeoms == 3 * capsule_links  # nothing dropped: URDF 1.0 shapes only


def _segment(chain, k: int) -> np.ndarray:
    """Origin of DH frame k + 1 in frame k at q = 0 (m)."""
    F = chain.frames(np.zeros(chain.n))
    return (np.linalg.inv(F[k]) @ F[k + 1])[:3, 3]


def _pose(pos, quat) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat(quat).as_matrix()
    T[:3, 3] = pos
    return T


def test_pybullet_urdf_frames_match_frames_q(chain, bullet, configs):
    """The joint frames PyBullet parsed (getJointInfo, double precision) composed with the joint motions
    give frames(q) to 1e-9 m; PyBullet's own link states (getLinkState returns float32 positions) agree
    with frames(q) as closely as navstack's own body does, and with that body to rounding error."""
    client, uid, own = bullet
    info = [client.getJointInfo(uid, j) for j in range(client.getNumJoints(uid))]
    assert [i[1].decode() for i in info] == [f"joint{k}" for k in range(1, 22)]
    assert [i[2] for i in info] == [p.JOINT_PRISMATIC] + [p.JOINT_REVOLUTE] * 19 + [p.JOINT_FIXED]
    np.testing.assert_array_equal([i[8] for i in info[:20]], chain.lower)
    np.testing.assert_array_equal([i[9] for i in info[:20]], chain.upper)
    # parentFrameOrn is reported inverted (PyBullet stores the parent-to-child rotation the other way round;
    # bullet3 issue #3253), hence the conjugate
    parsed = [_pose(i[14], np.r_[-np.asarray(i[15][:3]), i[15][3]]) for i in info]
    worst_parsed = worst_state = worst_own = 0.0
    for q in configs:
        F = chain.frames(q)
        T = np.eye(4)
        for j, (P, i) in enumerate(zip(parsed, info, strict=True)):
            axis = np.asarray(i[13])
            move = np.eye(4)
            if i[2] == p.JOINT_PRISMATIC:
                move[:3, 3] = axis * q[j]
            elif i[2] == p.JOINT_REVOLUTE:
                move[:3, :3] = Rotation.from_rotvec(axis * q[j]).as_matrix()
            T = T @ P @ move
            worst_parsed = max(worst_parsed, float(np.abs(T[:3, :] - F[j + 1, :3, :]).max()))
        for jj in range(chain.n):
            client.resetJointState(uid, jj, float(q[jj]))
        own.reset(q)
        states = client.getLinkStates(uid, list(range(21)), computeForwardKinematics=True)
        Fu = np.array([s[4] for s in states])
        Fo = own.link_frames_world()[:, :3, 3]
        worst_state = max(worst_state, float(np.abs(Fu - F[1:, :3, 3]).max()))
        worst_own = max(worst_own, float(np.abs(Fu - Fo).max()))
    print(f"PyBullet URDF, {N_CONFIGS} configurations: parsed joint frames vs frames(q) {worst_parsed:.2e}, "
          f"getLinkState vs frames(q) {worst_state:.2e} (float32 output), URDF body vs navstack body {worst_own:.2e}")
    assert worst_parsed < 1e-9
    assert worst_own < 1e-9
    assert worst_state < 1e-6  # PyBullet's reported link positions are float32 (~1e-7 relative at 3 m)


def test_pybullet_urdf_masses_and_inertias_match_navstack_body(bullet):
    client, uid, own = bullet
    assert client.getNumJoints(uid) == client.getNumJoints(own.body_id)
    for link in range(-1, client.getNumJoints(uid)):
        a, b = client.getDynamicsInfo(uid, link), client.getDynamicsInfo(own.body_id, link)
        assert a[0] == pytest.approx(b[0], abs=1e-12), f"mass of link {link}"
        np.testing.assert_allclose(a[2], b[2], atol=1e-12, err_msg=f"inertia of link {link}")
        np.testing.assert_allclose(a[3], b[3], atol=1e-12, err_msg=f"inertial frame of link {link}")
    assert sim_body.ARM_LINK_MASS == UrdfOptions().arm_mass
    assert sim_body.SERPENTINE_LINK_MASS == UrdfOptions().serpentine_mass


def _capsules_own(client, body: int, link: int):
    """(end point a, end point b, radius) of navstack's capsule on ``link``, in the link frame."""
    shapes = client.getCollisionShapeData(body, link)
    out = []
    for s in shapes:
        assert s[2] == p.GEOM_CAPSULE
        length, radius = s[3][0], s[3][1]
        T = _pose(s[5], s[6])
        out.append(((T @ [0, 0, -length / 2, 1])[:3], (T @ [0, 0, length / 2, 1])[:3], radius))
    return out


def _capsules_urdf(client, body: int, link: int):
    """The same from the URDF body: a cylinder's axis end points, checked against the two spheres."""
    shapes = client.getCollisionShapeData(body, link)
    if not shapes:
        return []
    cyl = [s for s in shapes if s[2] == p.GEOM_CYLINDER]
    sph = [s for s in shapes if s[2] == p.GEOM_SPHERE]
    assert len(cyl) == 1 and len(sph) == 2 and len(shapes) == 3
    length, radius = cyl[0][3][0], cyl[0][3][1]
    T = _pose(cyl[0][5], cyl[0][6])
    a, b = (T @ [0, 0, -length / 2, 1])[:3], (T @ [0, 0, length / 2, 1])[:3]
    centres = sorted((np.asarray(s[5]) for s in sph), key=lambda c: float(np.linalg.norm(c - a)))
    np.testing.assert_allclose(centres[0], a, atol=1e-12)
    np.testing.assert_allclose(centres[1], b, atol=1e-12)
    assert all(s[3][0] == radius for s in sph)
    return [(a, b, radius)]


def test_pybullet_urdf_collision_geometry_matches_navstack_capsules(bullet, chain):
    client, uid, own = bullet
    for link in range(client.getNumJoints(uid)):
        mine, theirs = _capsules_own(client, own.body_id, link), _capsules_urdf(client, uid, link)
        assert len(mine) == len(theirs), f"link {link}"
        for (a0, b0, r0), (a1, b1, r1) in zip(mine, theirs, strict=True):
            assert r1 == pytest.approx(r0, abs=1e-12)
            np.testing.assert_allclose(a1, a0, atol=1e-12)
            np.testing.assert_allclose(b1, b0, atol=1e-12)


def test_pybullet_urdf_distances_match_navstack_capsules(bullet, chain, configs):
    """Behaviour, not just data: a small probe sphere around each link is as far from the URDF body
    (cylinder + two spheres) as from navstack's capsule, within PyBullet's GJK tolerance."""
    client, uid, own = bullet
    q = configs[0]
    for j in range(chain.n):
        client.resetJointState(uid, j, float(q[j]))
    own.reset(q)
    probe = client.createMultiBody(0, client.createCollisionShape(p.GEOM_SPHERE, radius=0.001))
    F = chain.frames(q)
    rng = np.random.default_rng(7)
    worst, checked, inside = 0.0, 0, 0
    for k in range(1, 21):
        for _ in range(10):
            client.resetBasePositionAndOrientation(probe, (F[k, :3, 3] + 0.1 * rng.normal(size=3)).tolist(),
                                                   [0, 0, 0, 1])
            d_urdf = [c[8] for c in client.getClosestPoints(uid, probe, 1.0, linkIndexA=k - 1)]
            d_own = [c[8] for c in client.getClosestPoints(own.body_id, probe, 1.0, linkIndexA=k - 1)]
            assert bool(d_urdf) == bool(d_own)
            if not d_own:
                continue
            if min(d_own) > 0:
                worst = max(worst, abs(min(d_urdf) - min(d_own)))
                checked += 1
            else:  # inside: both report penetration (depths differ: a union's depth is its deepest child's)
                assert min(d_urdf) <= 0
                inside += 1
    assert checked > 100 and inside > 0
    assert worst < 5e-5, worst


def test_options_change_radius_and_validate(chain):
    text = chain.to_urdf(UrdfOptions(serpentine_radius=0.03, name="thick"))
    root = ET.fromstring(text)
    assert root.get("name") == "thick"
    radii = {float(s.get("radius")) for s in root.iter("sphere")}
    assert radii == {0.03, 0.06}
    with pytest.raises(ValueError, match="serpentine_radius"):
        UrdfOptions(serpentine_radius=-1.0)
    with pytest.raises(ValueError, match="velocity"):
        UrdfOptions(velocity=float("nan"))
    # radii as in world files (a 1e300 m capsule was written; PyBullet cannot load it sensibly)
    for key, v in [("arm_radius", 1e300), ("serpentine_radius", 0.6), ("serpentine_radius", 0.005),
                   ("arm_mass", 1e300), ("velocity", float("inf")), ("arm_radius", True)]:
        with pytest.raises(ValueError, match=key):
            UrdfOptions(**{key: v})
    assert UrdfOptions(arm_radius=0.5, serpentine_radius=0.01, arm_mass=1e6).arm_radius == 0.5


def test_cli_urdf_writes_file_and_stdout(tmp_path, capsys, chain):
    from navstack.cli import main

    out = tmp_path / "robot.urdf"
    assert main(["urdf", "--out", str(out)]) == 0
    assert out.read_text() == chain.to_urdf()
    capsys.readouterr()
    assert main(["urdf"]) == 0
    assert capsys.readouterr().out == chain.to_urdf()
    assert main(["urdf", "--out", str(tmp_path / "missing" / "x.urdf")]) == 2
    capsys.readouterr()
    assert main(["urdf", "--serpentine-radius", "1e300"]) == 2
    assert "serpentine_radius must be a number from 0.01 to 0.5 m" in capsys.readouterr().err
