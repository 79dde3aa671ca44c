"""Certified, converged reach maps: checked against the closed-form 3R IK, FK by hand and independent samples.

Independent sources:

- The planar 3R (4, 2, 1) dexterous annulus 3 <= r <= 5 (derived in
  test_analysis_reachmap.py) and the closed-form IK ``closed_form.planar.ik_3r``,
  which does not use the map.
- FK of the 3R by its position formula (the URDF's comment), not the FK kernel.
- Fresh FK samples from a seed the build never used, and IK from the test.
"""

import math

import numpy as np
import pytest

from manipkit.analysis.placement import base_placement, confirm_placement, placement_transforms
from manipkit.analysis.reachmap import HOW_NONE, build, load
from manipkit.analysis.reachstages import wilson
from manipkit.closed_form.planar import ik_3r
from manipkit.kinematics.ik_many import ik_many

VOXEL = 0.1


@pytest.fixture(scope="module")
def map_3r(planar_3r):
    return build(planar_3r, voxel=VOXEL, orientations=36, samples=2_000_000, method="hybrid", converge=0.001,
                 block_samples=1 << 15, manipulability=False)


def fk_3r(Q):
    """Tool (x, y, phi) of the 3R (4, 2, 1) by the formula in robots/planar_3r.urdf.xacro."""
    t1, t12, t123 = Q[:, 0], Q[:, 0] + Q[:, 1], Q[:, 0] + Q[:, 1] + Q[:, 2]
    return (4 * np.cos(t1) + 2 * np.cos(t12) + np.cos(t123), 4 * np.sin(t1) + 2 * np.sin(t12) + np.sin(t123), t123)


def test_every_voxel_bin_inside_the_dexterous_annulus_is_reached(map_3r):
    # Voxels whose centre is at least one voxel inside 3 <= r <= 5: every heading is reachable there (the
    # wrist p - (cos phi, sin phi) stays in the 2R annulus 2 <= |w| <= 6). Any bin the map calls unreachable
    # is a failure; the closed-form IK shows each such (voxel centre, bin heading) reachable.
    centres = map_3r.centers()[:, :, 0]
    r = np.hypot(centres[..., 0], centres[..., 1])
    inner = (r >= 3 + VOXEL) & (r <= 5 - VOXEL)
    assert inner.sum() > 0.8 * math.pi * (4.9**2 - 3.1**2) / VOXEL**2
    R = map_3r.orientations.rotations()
    headings = np.arctan2(R[:, 1, 0], R[:, 0, 0])  # the tool's x axis about z
    missed = np.argwhere(inner[..., None] & (map_3r.reach[:, :, 0, :] == HOW_NONE))
    reachable_by_ik = [bool(ik_3r(*centres[i, j, :2], headings[b], 4.0, 2.0, 1.0).success) for i, j, b in missed]
    assert missed.tolist() == [], f"{sum(reachable_by_ik)} of {len(missed)} missed bins reached by closed-form IK"
    assert all(ik_3r(*centres[i, j, :2], headings[b], 4.0, 2.0, 1.0).success
               for i, j, b in np.argwhere(inner[..., None] & np.ones(36, dtype=bool))[::997])


def test_every_reached_bin_holds_a_configuration_whose_fk_lands_in_it(map_3r):
    assert np.array_equal(map_3r.cert_keys, np.flatnonzero(map_3r.reach.reshape(-1) > HOW_NONE))
    x, y, phi = fk_3r(map_3r.cert_q)
    ijk, inside = map_3r.voxel_of(np.column_stack([x, y, np.zeros_like(x)]))
    turn = np.mod(np.rint(phi / (2 * math.pi / 36)), 36).astype(int)  # bins centred on k * 10 degrees
    assert inside.all()
    keys = np.ravel_multi_index(tuple(ijk.T), map_3r.shape) * 36 + turn
    assert np.array_equal(keys, map_3r.cert_keys)


def test_held_out_completeness_agrees_with_fresh_fk_poses_within_its_interval(planar_3r, map_3r):
    c = map_3r.settings["completeness"]
    assert c["n"] == 20_000 and c["low"] <= c["rate"] <= c["high"]
    Q = planar_3r.sample_q(20_000, seed=12345)  # a stream the build does not use
    T = planar_3r.fk(Q, base="base_link", tip="ee_link")
    fresh = float(np.mean(map_3r.query(T)))
    low, high = wilson(int(round(fresh * len(Q))), len(Q))
    assert max(low, c["low"]) <= min(high, c["high"])  # the two 95 % intervals overlap
    f = map_3r.settings["false_positive"]
    assert f["n"] == 200 and 0 <= f["failed"] <= f["n"] and f["high"] >= f["rate"]


def test_query_says_what_it_answers_and_confirm_answers_the_exact_pose(planar_3r, map_3r):
    Q = planar_3r.sample_q(20, seed=7)
    T = planar_3r.fk(Q, base="base_link", tip="ee_link")
    T_out = T.copy()
    T_out[:, 0, 3] += 20.0  # 20 m away: beyond the 7 m reach
    answer = map_3r.query(np.concatenate([T, T_out]), confirm=True, robot=planar_3r)
    assert "0.1 m voxel" in answer.resolution and "10 deg bins" in answer.resolution and answer.roll is None
    assert answer.confirmed[20:].sum() == 0 and answer.confirmed[:20].all()
    reached = planar_3r.fk(answer.q[:20], base="base_link", tip="ee_link")
    assert np.abs(reached - T).max() < 1e-5  # confirmed by FK of the answers
    assert np.array_equal(answer.reachable, map_3r.query(np.concatenate([T, T_out])))


def test_saved_map_keeps_its_certificates_and_checks(map_3r, tmp_path):
    again = load(map_3r.save(tmp_path / "m.zarr"))
    assert np.array_equal(again.cert_keys, map_3r.cert_keys) and np.array_equal(again.cert_q, map_3r.cert_q)
    assert again.settings["completeness"] == map_3r.settings["completeness"]
    assert "completeness: a held-out sample of 20000" in again.summary()


def test_converging_build_is_the_same_for_any_worker_count(planar_2r):
    options = dict(voxel=0.2, orientations=8, samples=200_000, block_samples=4096, converge=0.01, method="hybrid",
                   manipulability=False, fp_checks=20, holdout=2000)
    here = build(planar_2r, **options)
    there = build(planar_2r, workers=2, **options)
    assert here.settings["converged"] and here.settings["blocks"] < 200_000 // 4096
    assert here.settings == there.settings
    for name in ("reach", "voxel_q", "ik_keys", "ik_q", "cert_keys", "cert_q"):
        assert np.array_equal(getattr(here, name), getattr(there, name), equal_nan=True), name


def test_mobile_placement_confirmed_count_equals_independent_ik(load_robot):
    robot = load_robot("mobile_manipulator")
    reach_map = build(robot, base="base_footprint", voxel=0.08, orientations=8, samples=150000, fp_checks=20)
    hidden = placement_transforms(2.0, 1.0, math.pi / 2)
    targets = hidden @ robot.fk(robot.sample_q(8, seed=4), base="base_footprint", tip="ee_link")
    found = base_placement(reach_map, targets, xs=np.arange(0.0, 4.01, 0.25), ys=np.arange(-1.0, 3.01, 0.25), yaws=4)
    chosen = confirm_placement(reach_map, found, robot)
    # independent: IK from the printed placement, random starts only (not the map's certificates), full pose
    T_B = np.linalg.inv(placement_transforms(chosen.x, chosen.y, chosen.yaw)) @ targets
    independent = ik_many(robot, T_B, "base_footprint", "ee_link", mode="pose", tol=1e-6, restarts=100, seed=99)
    assert int(chosen.confirmed.sum()) == int(np.sum(independent.success))
    assert chosen.confirmed.sum() >= 6  # the hidden placement reaches all 8 exactly; one 0.25 m grid point of it
    assert "IK confirms" in chosen.summary() and "the map estimates" in chosen.summary()


def test_a_map_of_the_older_format_is_refused_with_rebuild(map_3r, tmp_path):
    import json

    from manipkit.errors import InputFileError

    path = map_3r.save(tmp_path / "old.zarr")
    meta = json.loads((path / "zarr.json").read_text())
    meta["attributes"]["format"] = "manipkit-reachmap-1"
    (path / "zarr.json").write_text(json.dumps(meta))
    with pytest.raises(InputFileError, match="older format .* rebuild it"):
        load(path)
