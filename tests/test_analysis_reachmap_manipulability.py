"""The manipulability overlay of manipkit.analysis.reachmap: best and mean Yoshikawa index per voxel.

Independent sources:

- The planar 2R (l1 = l2 = 1) by hand: Yoshikawa's index of its translation
  rows is l1 l2 |sin q2|, and the radius r of the tool fixes |q2|
  (r^2 = 2 + 2 cos q2), so every configuration reaching radius r has the
  index f(r) = r sqrt(4 - r^2) / 2 (derived in the test).
- The samples recomputed from the documented block seeds, placed by
  Pinocchio (``Robot.transform``), their index from ``Robot.jacobian`` and
  numpy's SVD (the product of the singular values of the linear rows).
"""

import math

import numpy as np
import pytest

from manipkit.analysis.reachmap import HOW_IK, ReachMapError, build, load
from manipkit.analysis.reachmap.plot import plot_reachmap
from manipkit.text import short_text


def svd_index(J_linear):
    """Yoshikawa's index: the product of the singular values of the linear rows (numpy SVD)."""
    return float(np.prod(np.linalg.svd(J_linear, compute_uv=False)))


def f_2r(r):
    # Planar 2R, l1 = l2 = 1: r^2 = l1^2 + l2^2 + 2 l1 l2 cos q2 = 2 + 2 cos q2, so cos q2 = r^2 / 2 - 1 and
    # sin^2 q2 = 1 - (r^2 / 2 - 1)^2 = r^2 - r^4 / 4 = r^2 (4 - r^2) / 4: the index |sin q2| = r sqrt(4 - r^2) / 2.
    # It rises on [0, sqrt 2] (to 1, the elbow at 90 degrees) and falls on [sqrt 2, 2].
    r = np.minimum(r, 2.0)
    return r * np.sqrt(4.0 - r * r) / 2.0


@pytest.fixture(scope="module")
def map_2r(planar_2r):
    return build(planar_2r, voxel=0.2, orientations=1, samples=12000, block_samples=4096, seed=5)


def test_planar_2r_best_index_per_voxel_is_the_hand_value_over_its_radii(map_2r):
    best, mean = map_2r.manipulability, map_2r.manipulability_mean
    reached = map_2r.reachable
    assert np.isfinite(best[reached]).all() and np.isnan(best[~reached]).all() and np.isnan(mean[~reached]).all()
    centres = map_2r.centers()
    x, y = np.abs(centres[..., 0]), np.abs(centres[..., 1])
    near = np.hypot(np.maximum(x - 0.1, 0.0), np.maximum(y - 0.1, 0.0))  # radii a square of edge 0.2 spans
    far = np.hypot(x + 0.1, y + 0.1)
    highest = f_2r(np.clip(math.sqrt(2.0), near, np.minimum(far, 2.0)))  # f over [near, far]: its largest value
    lowest = np.minimum(f_2r(near), f_2r(far))  # and its smallest (f is unimodal)
    assert (best[reached] <= highest[reached] + 1e-12).all() and (best[reached] >= lowest[reached] - 1e-12).all()
    assert (mean[reached] <= best[reached] + 1e-12).all() and (mean[reached] >= lowest[reached] - 1e-12).all()
    # the voxel holding radius sqrt 2 (elbow at 90 degrees) has the best index of the map, 1 to its sampling
    assert float(np.nanmax(best)) > 0.999 and float(np.nanmax(best)) <= 1.0 + 1e-12


def test_planar_2r_best_and_mean_are_the_documented_samples_by_hand(map_2r):
    np.testing.assert_allclose(map_2r.axes, np.eye(3), atol=1e-12)  # the plane's u, v are x, y
    best = np.full(map_2r.shape[:2], -np.inf)
    total, count = np.zeros(map_2r.shape[:2]), np.zeros(map_2r.shape[:2])
    for block in range(3):  # 12000 samples in blocks of 4096, seeds (5, 0, block), joints in [-pi, pi]
        n = min(4096, 12000 - block * 4096)
        t = -math.pi + np.random.default_rng([5, 0, block]).random((n, 2)) * 2.0 * math.pi
        x = np.cos(t[:, 0]) + np.cos(t[:, 0] + t[:, 1])
        y = np.sin(t[:, 0]) + np.sin(t[:, 0] + t[:, 1])
        i = np.rint((x - map_2r.origin[0]) / 0.2).astype(int)
        j = np.rint((y - map_2r.origin[1]) / 0.2).astype(int)
        w = np.abs(np.sin(t[:, 1]))  # l1 l2 |sin q2|
        np.maximum.at(best, (i, j), w)
        np.add.at(total, (i, j), w)
        np.add.at(count, (i, j), 1)
    hit = count > 0
    np.testing.assert_array_equal(hit, map_2r.reachable[:, :, 0])
    np.testing.assert_allclose(map_2r.manipulability[:, :, 0][hit], best[hit], rtol=0, atol=1e-12)
    np.testing.assert_allclose(map_2r.manipulability_mean[:, :, 0][hit], (total / np.maximum(count, 1))[hit],
                               rtol=0, atol=1e-12)


def test_spatial_map_matches_pinocchio_placements_and_svd_of_each_sample(iiwa14):
    m = build(iiwa14, voxel=0.3, orientations=4, samples=400, block_samples=256, seed=2)
    low = np.array([j.lower for j in iiwa14.joints])
    high = np.array([j.upper for j in iiwa14.joints])
    best, total, count = {}, {}, {}
    for block, n in ((0, 256), (1, 144)):
        Q = low + np.random.default_rng([2, 0, block]).random((n, 7)) * (high - low)
        for q in Q:
            T = iiwa14.transform("base_link", "ee_link", q)  # Pinocchio
            ijk = tuple(np.rint((T[:3, 3] - m.origin) / 0.3).astype(int))
            w = svd_index(iiwa14.jacobian(q, base="base_link", tip="ee_link")[:3])
            best[ijk] = max(best.get(ijk, -1.0), w)
            total[ijk] = total.get(ijk, 0.0) + w
            count[ijk] = count.get(ijk, 0) + 1
    assert set(map(tuple, np.argwhere(m.reachable))) == set(best)
    for ijk in best:
        assert m.manipulability[ijk] == pytest.approx(best[ijk], rel=1e-9, abs=1e-12)
        assert m.manipulability_mean[ijk] == pytest.approx(total[ijk] / count[ijk], rel=1e-9, abs=1e-12)
        # the stored configuration is one of the voxel's: its SVD index is at most the best
        assert svd_index(iiwa14.jacobian(m.voxel_q[ijk])[:3]) <= m.manipulability[ijk] + 1e-12
    w_best, where = m.best_manipulability()
    assert w_best == pytest.approx(max(best.values()), rel=1e-9)
    assert f"best {short_text(w_best, 4)} at" in m.summary() and m.voxel_of(where)[0].tolist() == list(max(best, key=best.get))


def test_ik_answers_count_in_the_planar_3r_overlay_with_the_plane_rows(planar_3r):
    m = build(planar_3r, voxel=0.5, orientations=8, samples=3000, method="hybrid", block_samples=1024)
    # Voxels reached by IK only: their best and mean come from the IK answers alone. The 3R's translation
    # rows (vx, vy, vz) have vz = 0, so the index is taken over the rows of the plane (u, v = the grid axes).
    u, v = m.axes[:, 0], m.axes[:, 1]
    by_voxel = {}
    for key, q in zip(m.ik_keys, m.ik_q):
        J = planar_3r.jacobian(q, base="base_link", tip="ee_link")[:3]
        by_voxel.setdefault(int(key) // m.orientations.size, []).append(svd_index(np.stack([u @ J, v @ J])))
    ik_only = np.flatnonzero((m.how == HOW_IK).reshape(-1))
    assert ik_only.size > 0
    best, mean = m.manipulability.reshape(-1), m.manipulability_mean.reshape(-1)
    for voxel in ik_only:
        assert best[voxel] == pytest.approx(max(by_voxel[voxel]), abs=1e-12)
        assert mean[voxel] == pytest.approx(np.mean(by_voxel[voxel]), abs=1e-12)
    assert np.nanmin(best) >= 0.0 and np.nanmax(best) > 1.0  # not the zero of a 3x3 with a zero row


def test_one_worker_or_two_give_the_same_overlay_bits(planar_3r):
    here = build(planar_3r, voxel=0.5, orientations=4, samples=6000, block_samples=512, method="hybrid")
    there = build(planar_3r, voxel=0.5, orientations=4, samples=6000, block_samples=512, method="hybrid", workers=2)
    assert here.manipulability.tobytes() == there.manipulability.tobytes()
    assert here.manipulability_mean.tobytes() == there.manipulability_mean.tobytes()


def test_overlay_round_trips_and_can_be_skipped(map_2r, planar_2r, tmp_path):
    again = load(map_2r.save(tmp_path / "m.zarr"))
    np.testing.assert_array_equal(again.manipulability, map_2r.manipulability)
    np.testing.assert_array_equal(again.manipulability_mean, map_2r.manipulability_mean)
    assert again.summary() == map_2r.summary() and "manipulability (Yoshikawa" in again.summary()
    plain = build(planar_2r, voxel=0.2, orientations=1, samples=12000, block_samples=4096, seed=5, manipulability=False)
    np.testing.assert_array_equal(plain.reach, map_2r.reach)
    np.testing.assert_array_equal(plain.voxel_q, map_2r.voxel_q)
    assert plain.manipulability is None and plain.settings["manipulability"] is False
    plain_again = load(plain.save(tmp_path / "plain.zarr"))
    assert plain_again.manipulability is None and "manipulability" not in plain_again.summary()
    with pytest.raises(ReachMapError, match="built without manipulability"):
        plot_reachmap(plain_again, tmp_path / "w.png", layer="manipulability")


def test_plot_layers(map_2r, tmp_path):
    plot_reachmap(map_2r, tmp_path / "w.png", layer="manipulability")
    assert (tmp_path / "w.png").stat().st_size > 10_000
    with pytest.raises(ReachMapError, match="unknown layer 'speed'; layers: index, manipulability"):
        plot_reachmap(map_2r, tmp_path / "x.png", layer="speed")
