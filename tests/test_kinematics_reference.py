"""navstack.kinematics against an independent Pinocchio build of Figure 2 (skipped without ``pin``)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from navstack import jpl_serpentine  # noqa: E402
from navstack._pinocchio import build_pinocchio  # noqa: E402

N_SAMPLES = 100


@pytest.fixture(scope="module")
def chains():
    chain = jpl_serpentine()
    return chain, build_pinocchio(chain)


def _random_qs(chain, seed: int = 7) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(chain.lower, chain.upper, size=(N_SAMPLES, chain.n))


def test_model_has_the_chain_structure(chains):
    chain, ref = chains
    assert ref.model.nq == chain.n == 20
    assert ref.model.nv == chain.n
    # one prismatic joint (the lathe bed) then 19 revolute joints, all about z
    shortnames = [ref.model.joints[j].shortname() for j in range(1, ref.model.njoints)]
    assert shortnames[0] == "JointModelPZ"
    assert shortnames[1:] == ["JointModelRZ"] * 19


def test_frames_match_pinocchio(chains):
    chain, ref = chains
    worst = 0.0
    for q in _random_qs(chain):
        ours = chain.frames(q)
        theirs = ref.frames(q)
        assert ours.shape == theirs.shape == (22, 4, 4)
        worst = max(worst, float(np.abs(ours - theirs).max()))
    assert worst <= 1e-12, worst


def test_default_posture_backbone_matches_pinocchio(chains):
    chain, ref = chains
    pts, _ = ref.points_and_jacobians(chain.q_default)
    np.testing.assert_allclose(pts[0], [0.867, -0.108, 1.809], atol=1e-3)  # tip
    np.testing.assert_allclose(pts[-1], [0.867, -0.108, 0.609], atol=1e-3)  # J6
    np.testing.assert_allclose(chain.points_and_jacobians(chain.q_default)[0], pts, atol=1e-12)


def test_point_jacobians_match_pinocchio_local_world_aligned(chains):
    chain, ref = chains
    worst_p = worst_j = 0.0
    for q in _random_qs(chain, seed=11):
        pts, jac = chain.points_and_jacobians(q)
        rpts, rjac = ref.points_and_jacobians(q)
        assert jac.shape == rjac.shape == (7, 3, 20)
        worst_p = max(worst_p, float(np.abs(pts - rpts).max()))
        worst_j = max(worst_j, float(np.abs(jac - rjac).max()))
    assert worst_p <= 1e-12, worst_p
    assert worst_j <= 1e-12, worst_j
