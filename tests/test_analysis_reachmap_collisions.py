"""Reach maps that count only collision-free configurations (``build(..., collisions=)``, ``reachmap --collisions``).

Every configuration a filtered map stores (first sample per voxel, IK answers)
is checked here by a geometry model built in the test with Pinocchio and coal
alone, against the floor plane and the robot itself.
"""

import coal
import numpy as np
import pinocchio as pin
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.analysis.reachmap import build
from manipkit.kinematics.collisions import CollisionChecker, CollisionSettings


def independent_contacts(robot, Q, pairs) -> np.ndarray:
    """(N,) bool: some pair of ``pairs`` (link names, 'floor' for z = 0 in the root frame) in contact, by Pinocchio
    and coal alone (the URDF's collision primitives, a half-space for the floor)."""
    geom = pin.buildGeomFromUrdfString(robot.model, robot.urdf, pin.GeometryType.COLLISION)
    floor = pin.GeometryObject("floor", 0, 0, pin.SE3.Identity(), coal.Halfspace(np.array([0, 0, 1.0]), 0.0))
    geom.addGeometryObject(floor)
    names = [robot.model.frames[o.parentFrame].name for o in geom.geometryObjects][:-1] + ["floor"]
    wanted = {tuple(sorted(p)) for p in pairs}
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if tuple(sorted((names[i], names[j]))) in wanted:
                geom.addCollisionPair(pin.CollisionPair(i, j))
    data, gdata = robot.model.createData(), geom.createData()
    return np.array([pin.computeCollisions(robot.model, data, geom, gdata, robot.pinocchio_configuration(q), True)
                     for q in Q])


@pytest.fixture(scope="module")
def iiwa_maps(iiwa14):
    settings = CollisionSettings.parse(iiwa14, "self,floor", floor=0.0)
    options = dict(voxel=0.15, orientations=8, samples=20_000, manipulability=False)
    return build(iiwa14, **options), build(iiwa14, **options, collisions=settings), settings


def test_a_filtered_map_reaches_a_subset_and_records_its_settings(iiwa_maps, tmp_path):
    plain, filtered, settings = iiwa_maps
    assert (filtered.reach <= plain.reach).all()
    assert filtered.reachable.sum() < plain.reachable.sum()  # the floor cuts the lower half
    assert filtered.settings["collisions"] == {"checked": ["self", "floor"], "floor": 0.0, "geometry": "hulls",
                                               "srdf": None, "disabled_pairs": 0}
    assert "collision-free only: self and floor (hulls geometry, floor at z = 0 m)" in filtered.summary()
    saved = manipkit.reachmap.load(filtered.save(tmp_path / "iiwa.zarr"))
    assert saved.settings["collisions"] == filtered.settings["collisions"]


def test_every_stored_configuration_is_collision_free_by_an_independent_check(iiwa_maps, iiwa14):
    _, filtered, settings = iiwa_maps
    Q = filtered.voxel_q.reshape(-1, filtered.voxel_q.shape[-1])
    Q = Q[~np.isnan(Q).any(axis=1)]
    assert len(Q) > 100
    pairs = settings.checker(iiwa14).pairs
    assert not independent_contacts(iiwa14, Q, pairs).any()
    # and the plain map's stored configurations include some that are not
    plain = iiwa_maps[0].voxel_q.reshape(-1, Q.shape[1])
    plain = plain[~np.isnan(plain).any(axis=1)]
    assert independent_contacts(iiwa14, plain, pairs).any()


def test_hybrid_ik_answers_are_collision_free_too(planar_2r):
    # planar 2R (links 1 m): the second link folded back onto the base disc collides; IK answers that do are dropped
    settings = CollisionSettings.parse(planar_2r, "self")
    reach_map = build(planar_2r, voxel=0.25, orientations=4, samples=300, method="hybrid", collisions=settings)
    checker = CollisionChecker(planar_2r)
    assert len(reach_map.ik_q) > 0
    assert not checker.in_collision(reach_map.ik_q).any()


def test_cli_reachmap_collisions_and_its_refusals(tmp_path):
    result = run_cli("manipkit", "reachmap", "--robot", "planar_2r", "--voxel", "0.25", "--orientations", "1",
                     "--samples", "500", "-o", tmp_path / "p.zarr", "--collisions", "self", status=0)
    assert "collision-free only: self (hulls geometry)" in result.stdout
    bad = run_cli("manipkit", "reachmap", "--robot", "planar_2r", "-o", tmp_path / "q.zarr", "--collisions", "walls")
    assert bad.returncode == 2 and bad.stderr == "manipkit: error: collisions 'walls': give self, floor, self,floor or none\n"
    placement = run_cli("manipkit", "base-placement", "--robot", "planar_2r", "--targets", tmp_path / "none.txt",
                        "--map", tmp_path / "p.zarr", "--collisions", "self")
    assert placement.returncode == 2


def test_checking_one_sample_per_voxel_bin_gives_the_same_map(iiwa14):
    # Without the manipulability statistics a block checks only the first sample of each voxel-bin not reached in an
    # earlier round (then the next where it collides); with them every sample is checked. 20 blocks of 1000 are five
    # rounds, so later rounds skip bins. Reach, certificates and first configurations must be identical.
    settings = CollisionSettings.parse(iiwa14, "self,floor", floor=0.0)
    options = dict(voxel=0.15, orientations=8, samples=20_000, block_samples=1000, collisions=settings)
    lazy, full = build(iiwa14, **options, manipulability=False), build(iiwa14, **options, manipulability=True)
    assert (lazy.reach == full.reach).all()
    assert np.array_equal(lazy.voxel_q, full.voxel_q, equal_nan=True)
    assert np.array_equal(lazy.cert_keys, full.cert_keys) and np.array_equal(lazy.cert_q, full.cert_q)
    there = build(iiwa14, **options, manipulability=False, workers=2)  # the skipped bins do not depend on the workers
    for name in ("reach", "voxel_q", "cert_keys", "cert_q"):
        assert np.array_equal(getattr(lazy, name), getattr(there, name), equal_nan=True), name


def test_first_free_finds_each_groups_first_free_row(panda):
    checker_settings = CollisionSettings.parse(panda, "self")
    Q = panda.sample_q(400, seed=2)
    groups = np.arange(400) % 7 - 1  # groups -1 (skipped) .. 5
    first = checker_settings.first_free(panda, Q, groups)
    free = ~CollisionChecker(panda).in_collision(Q)
    expected = np.zeros(400, dtype=bool)
    for g in range(6):
        rows = np.flatnonzero((groups == g) & free)
        if rows.size:
            expected[rows[0]] = True
    assert (first == expected).all()
