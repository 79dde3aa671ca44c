"""manipkit.analysis.reachmap and orientations: maps checked against closed-form workspaces and FK.

Independent sources:

- The planar 3R (4, 2, 1) annuli, derived by hand below and taken from
  ``closed_form.planar_workspace.workspace_3r``.
- The planar 2R (1, 1) disc r <= l1 + l2 = 2 (``workspace_2r``).
- The marks of the FK stage recomputed in the test from the documented
  sampling (the block seeds) with the 3R's closed-form position formula, not
  the FK kernel.
- Every stored configuration and every IK answer re-measured by Pinocchio
  (``Robot.transform``).
"""

import math

import numpy as np
import pytest

from manipkit.analysis import reachmap
from manipkit.analysis.reachmap import HOW_IK, HOW_NONE, HOW_SAMPLE, ReachMapError, build, load
from manipkit.analysis.reachmap.orientations import (
    fibonacci_directions,
    nearest_direction,
    planar_orientations,
    spatial_orientations,
)
from manipkit.closed_form.planar_workspace import workspace_2r, workspace_3r
from manipkit.errors import InputFileError, OutputError
from manipkit.spatial.rotations import rot_y, rot_z

VOXEL = 0.5
SAMPLES = 20000


@pytest.fixture(scope="module")
def map_3r(planar_3r):
    return build(planar_3r, voxel=VOXEL, orientations=8, samples=SAMPLES, method="hybrid", block_samples=4096)


def square_distances(centres, half):
    """(nearest, farthest) distance from the base origin to each axis-aligned square of half-edge ``half``."""
    x, y = np.abs(centres[..., 0]), np.abs(centres[..., 1])
    near = np.hypot(np.maximum(x - half, 0.0), np.maximum(y - half, 0.0))
    return near, np.hypot(x + half, y + half)


def test_planar_3r_map_reproduces_the_reachable_and_dexterous_annuli(map_3r):
    # By hand, l = (4, 2, 1): the tool reaches r in [l1 - l2 - l3, l1 + l2 + l3] = [1, 7] (l1 > l2 + l3).
    # With the tool at angle phi, the wrist w = p - l3 (cos phi, sin phi) must lie in the 2R annulus
    # |w| in [l1 - l2, l1 + l2] = [2, 6]. Every phi works iff the circle of radius l3 = 1 about p lies in
    # that annulus: r - 1 >= 2 and r + 1 <= 6, so the dexterous annulus is r in [3, 5].
    workspace = workspace_3r(4.0, 2.0, 1.0)
    (r_min, r_max), ((d_min, d_max),) = workspace.reachable, workspace.dexterous
    assert (r_min, r_max, d_min, d_max) == (1.0, 7.0, 3.0, 5.0)
    near, far = square_distances(map_3r.centers(), VOXEL / 2)
    reachable, dexterous = map_3r.reachable, map_3r.dexterous
    # Reachable: exactly the voxels the annulus touches, among those wholly inside or outside it.
    assert not (reachable & ((near > r_max) | (far < r_min))).any()
    assert reachable[(near >= r_min) & (far <= r_max)].all()
    # Dexterous: every voxel wholly inside [3, 5]; none farther than one voxel outside it. (Just outside,
    # a voxel's 45-degree bins may each be hit somewhere in it; one voxel out, at r = 5.5, the tool angles
    # within 115.7 degrees of the radial direction are reachable only (cos > (r^2 - 35) / (2 r)), so two
    # whole bins are missed; at r = 2.5 those within 49.5 degrees are missed.)
    assert dexterous[(near >= d_min) & (far <= d_max)].all()
    assert not (dexterous & ((near > d_max + VOXEL) | (far < d_min - VOXEL))).any()
    assert dexterous.sum() > 0.8 * math.pi * (d_max**2 - d_min**2) / VOXEL**2


def test_planar_2r_map_is_the_disc_of_radius_l1_plus_l2(planar_2r):
    m = build(planar_2r, voxel=0.2, orientations=1, samples=20000)
    (r_min, r_max) = workspace_2r(1.0, 1.0).reachable
    assert (r_min, r_max) == (0.0, 2.0)
    near, far = square_distances(m.centers(), 0.1)
    assert not (m.reachable & (near > r_max)).any()
    assert m.reachable[far <= r_max].all()
    assert m.shape[2] == 1 and m.orientations.kind == "planar"


def test_fk_marks_are_the_documented_samples_binned_by_hand(planar_3r):
    m = build(planar_3r, voxel=VOXEL, orientations=8, samples=10000, block_samples=4096, seed=3, method="fk")
    expected = np.zeros_like(m.reach)
    for block in range(3):
        n = min(4096, 10000 - block * 4096)
        t = -math.pi + np.random.default_rng([3, 0, block]).random((n, 3)) * 2.0 * math.pi  # continuous joints
        a1, a12, a123 = t[:, 0], t[:, 0] + t[:, 1], t.sum(axis=1)
        x = 4 * np.cos(a1) + 2 * np.cos(a12) + np.cos(a123)
        y = 4 * np.sin(a1) + 2 * np.sin(a12) + np.sin(a123)
        i = np.rint((x - m.origin[0]) / VOXEL).astype(int)
        j = np.rint((y - m.origin[1]) / VOXEL).astype(int)
        b = np.mod(np.rint(a123 / (2 * math.pi / 8)), 8).astype(int)  # bin k is centred on k * 45 degrees
        expected[i, j, 0, b] = HOW_SAMPLE
    np.testing.assert_array_equal(m.reach, expected)
    np.testing.assert_allclose(m.origin, [-7.5, -7.5, 0.0], atol=1e-12)  # reach bound 7 m: 15 voxels each side


def test_many_rounds_keep_every_bins_and_voxels_first_sample(planar_3r):
    # 40 blocks of 250 run in three rounds (16, 16, 8); each block leaves out what earlier rounds reached. The
    # map must still be every sample binned by hand, with each voxel's and each voxel-bin's first sample stored.
    m = build(planar_3r, voxel=VOXEL, orientations=8, samples=10000, block_samples=250, seed=4, manipulability=False,
              method="fk")
    t = -math.pi + np.concatenate([np.random.default_rng([4, 0, b]).random((250, 3)) for b in range(40)]) * 2 * math.pi
    a1, a12, a123 = t[:, 0], t[:, 0] + t[:, 1], t.sum(axis=1)
    i = np.rint((4 * np.cos(a1) + 2 * np.cos(a12) + np.cos(a123) - m.origin[0]) / VOXEL).astype(int)
    j = np.rint((4 * np.sin(a1) + 2 * np.sin(a12) + np.sin(a123) - m.origin[1]) / VOXEL).astype(int)
    b = np.mod(np.rint(a123 / (2 * math.pi / 8)), 8).astype(int)
    voxel = i * m.shape[1] + j  # one layer: k = 0
    keys, first_of_key = np.unique(voxel * 8 + b, return_index=True)
    voxels, first = np.unique(voxel, return_index=True)
    assert np.array_equal(np.flatnonzero(m.reach.reshape(-1)), keys)
    assert np.array_equal(m.cert_keys, keys)
    np.testing.assert_array_equal(m.cert_q, t[first_of_key])
    np.testing.assert_array_equal(m.voxel_q.reshape(-1, 3)[voxels], t[first])
    assert m.settings["blocks"] == 40


def test_every_stored_configuration_reaches_its_voxel_and_a_marked_bin(map_3r, planar_3r):
    idx = np.argwhere(map_3r.reachable)
    how = map_3r.how
    for i, j, k in idx:
        q = map_3r.voxel_q[i, j, k]
        if how[i, j, k] != HOW_SAMPLE:
            assert np.isnan(q).all()
            continue
        T = planar_3r.transform("base_link", "ee_link", q)  # Pinocchio
        ijk, inside = map_3r.voxel_of(T[:3, 3])
        assert inside and tuple(ijk) == (i, j, k)
        assert map_3r.query(T, interpolate=False)  # the certified voxel-bin answer
    assert np.isnan(map_3r.voxel_q[~map_3r.reachable]).all()


def test_hybrid_ik_cells_are_reached_exactly_at_the_voxel_centre(map_3r, planar_3r):
    assert map_3r.ik_keys.size > 0
    bins = map_3r.orientations.rotations()
    centres = map_3r.centers().reshape(-1, 3)
    flat = map_3r.reach.reshape(-1)
    for key, q in zip(map_3r.ik_keys, map_3r.ik_q):
        assert flat[key] == HOW_IK
        voxel, b = divmod(int(key), map_3r.orientations.size)
        T = planar_3r.transform("base_link", "ee_link", q)
        assert np.linalg.norm(T[:3, 3] - centres[voxel]) < 1e-9
        assert np.abs(T[:3, :3] - bins[b]).max() < 1e-9


def test_spatial_hybrid_map_ik_cells_and_samples_check_by_fk(iiwa14):
    m = build(iiwa14, voxel=0.3, orientations=(6, 2), samples=4000, method="hybrid", block_samples=2048)
    assert m.orientations.kind == "spatial" and m.settings["ik_mode"] == "pose"
    assert (m.reach == HOW_IK).sum() == m.ik_keys.size > 0
    rng = np.random.default_rng(0)
    pick = rng.choice(m.ik_keys.size, size=min(40, m.ik_keys.size), replace=False)
    centres, bins = m.centers().reshape(-1, 3), m.orientations.rotations()
    for key, q in zip(m.ik_keys[pick], m.ik_q[pick]):
        voxel, b = divmod(int(key), m.orientations.size)
        T = iiwa14.transform("base_link", "ee_link", q)
        assert np.linalg.norm(T[:3, 3] - centres[voxel]) < 1e-9 and np.abs(T[:3, :3] - bins[b]).max() < 1e-9
        assert not iiwa14.outside_limits(q).any()
    sampled = np.argwhere(m.how == HOW_SAMPLE)
    for i, j, k in sampled[rng.choice(len(sampled), size=40, replace=False)]:
        T = iiwa14.transform("base_link", "ee_link", m.voxel_q[i, j, k])
        assert tuple(m.voxel_of(T[:3, 3])[0]) == (i, j, k) and m.query(T, interpolate=False)


def test_unseen_fk_poses_are_in_the_map(map_3r, planar_3r):
    T = planar_3r.fk(planar_3r.sample_q(2000, seed=77), base="base_link", tip="ee_link")
    assert map_3r.query(T).mean() >= 0.95


def test_query_and_index_at_outside_and_across_the_plane(map_3r):
    far = np.eye(4)
    far[0, 3] = 20.0
    assert map_3r.query(far) is False and map_3r.index_at([20.0, 0.0, 0.0]) == 0.0
    assert map_3r.index_at([4.0, 0.0, 0.0]) == 1.0
    assert map_3r.index_at([4.0, 0.0, 1.0]) == 0.0  # off the arm's plane
    assert map_3r.index_at(np.zeros((2, 5, 3))).shape == (2, 5)
    flat = np.eye(4)
    flat[0, 3] = 4.0
    tilted = flat.copy()
    tilted[:3, :3] = rot_y(0.6)  # the tool's z axis leaves the arm's axis: no planar configuration gives it
    assert map_3r.query(flat) is True and map_3r.query(tilted) is False


def test_one_worker_process_or_two_give_the_same_map(planar_3r, map_3r):
    local = build(planar_3r, voxel=VOXEL, orientations=8, samples=SAMPLES, method="hybrid", block_samples=4096,
                  workers=2)
    np.testing.assert_array_equal(local.reach, map_3r.reach)
    np.testing.assert_array_equal(local.voxel_q, map_3r.voxel_q)
    np.testing.assert_array_equal(local.ik_keys, map_3r.ik_keys)
    np.testing.assert_array_equal(local.ik_q, map_3r.ik_q)
    assert local.manipulability.tobytes() == map_3r.manipulability.tobytes()
    assert local.manipulability_mean.tobytes() == map_3r.manipulability_mean.tobytes()


def test_an_existing_scheduler_gives_the_same_map(planar_3r, map_3r):
    from distributed import LocalCluster

    here = map_3r  # built here with these options (a planar arm's default method is "hybrid", as map_3r's)
    assert here.method == "hybrid"
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        there = build(planar_3r, voxel=VOXEL, orientations=8, samples=SAMPLES, block_samples=4096,
                      scheduler=cluster.scheduler_address)
    assert there.method == here.method
    np.testing.assert_array_equal(there.reach, here.reach)
    np.testing.assert_array_equal(there.voxel_q, here.voxel_q)


def test_save_and_load_round_trip(map_3r, tmp_path):
    path = map_3r.save(tmp_path / "m.zarr")
    again = load(path)
    for name in ("reach", "origin", "axes", "voxel_q", "ik_keys", "ik_q", "manipulability", "manipulability_mean"):
        np.testing.assert_array_equal(getattr(again, name), getattr(map_3r, name))
    assert (again.robot, again.frame, again.base, again.method, again.voxel) == ("planar_3r", "ee_link", "base_link", "hybrid", VOXEL)
    assert again.settings == map_3r.settings and again.summary() == map_3r.summary()
    np.testing.assert_allclose(again.orientations.rotations(), map_3r.orientations.rotations())
    map_3r.save(path)  # a map may be replaced


def test_save_and_load_refuse_what_is_not_a_map(map_3r, tmp_path):
    (tmp_path / "photos").mkdir()
    with pytest.raises(OutputError, match="not a reachability map"):
        map_3r.save(tmp_path / "photos")
    with pytest.raises(OutputError, match="no such folder"):
        map_3r.save(tmp_path / "missing" / "m.zarr")
    with pytest.raises(InputFileError, match="not a manipkit reachability map"):
        load(tmp_path / "photos")
    with pytest.raises(InputFileError, match="no such reachability map"):
        load(tmp_path / "nothing.zarr")


def test_summary_counts(map_3r):
    text = map_3r.summary()
    assert f"dexterous (index = 1): {int(map_3r.dexterous.sum())} voxels" in text
    assert f"{int((map_3r.reach == HOW_IK).sum())} by IK" in text
    assert map_3r.how.max() <= HOW_IK and (map_3r.how[~map_3r.reachable] == HOW_NONE).all()


# ---------------------------------------------------------------------------
# Orientation sets


def test_fibonacci_directions_cover_the_sphere_evenly():
    d = fibonacci_directions(200)
    nearest = np.sort(np.arccos(np.clip(d @ d.T, -1, 1)), axis=1)[:, 1]
    # 200 equal caps of area 4 pi / 200: neighbours about sqrt(4 pi / 200) = 0.25 rad apart
    assert 0.15 < nearest.min() and nearest.max() < 0.3
    assert np.abs(d.mean(axis=0)).max() < 0.01


def test_nearest_direction_is_the_largest_dot_product():
    rng = np.random.default_rng(4)
    directions, v = fibonacci_directions(200), rng.normal(size=(5000, 3))
    np.testing.assert_array_equal(nearest_direction(v, directions), np.argmax(v @ directions.T, axis=1))
    assert nearest_direction(v.reshape(50, 100, 3), directions).shape == (50, 100)


def test_spatial_bins_contain_their_centres_and_ignore_roll_when_asked():
    bins = spatial_orientations(30, 6)
    R = bins.rotations()
    np.testing.assert_array_equal(bins.bin_of(R), np.arange(180))
    np.testing.assert_array_equal(bins.bin_of(R @ rot_z(0.2)), np.arange(180))  # 0.2 rad < half a roll bin (0.52)
    assert np.allclose(R @ np.swapaxes(R, 1, 2), np.eye(3)) and np.allclose(np.linalg.det(R), 1.0)
    directions_only = spatial_orientations(30, 1)
    spun = directions_only.rotations() @ rot_z(2.5)
    np.testing.assert_array_equal(directions_only.bin_of(spun), np.arange(30))


def test_planar_bins_are_turns_about_the_axis():
    # Axis y: a turn of t about y moves the tool's x axis to (cos t, 0, -sin t); u = x, v = a x u = -z.
    bins = planar_orientations(12, [0, 1.0, 0], [1.0, 0, 0], [0, 1.0, 0], [1.0, 0, 0])
    np.testing.assert_array_equal(bins.bin_of(bins.rotations()), np.arange(12))
    assert bins.bin_of(rot_y(2 * math.pi / 12 * 3 + 0.1)) == 3


def test_planar_and_spatial_arms_are_told_apart(planar_3r, iiwa14, course_arm):
    assert build(planar_3r, voxel=2.0, samples=100).orientations.kind == "planar"
    for robot in (iiwa14, course_arm):
        assert build(robot, voxel=0.5, orientations=4, samples=100).orientations.kind == "spatial"


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"voxel": 0.0}, "voxel 0.0"),
        ({"voxel": float("nan")}, "voxel nan"),
        ({"method": "ik"}, "unknown method 'ik'"),
        ({"samples": 0}, "samples 0"),
        ({"orientations": "5x"}, "orientations '5x'"),
        ({"orientations": (8, 2)}, "the arm is planar"),
        ({"workers": 0}, "workers 0"),
        ({"workers": 1, "scheduler": "tcp://127.0.0.1:1"}, "not both"),
        ({"voxel": 1e-4}, "use a coarser voxel"),
    ],
)
def test_bad_options_are_one_line_errors(planar_3r, options, message):
    with pytest.raises(ReachMapError, match=message):
        build(planar_3r, **{"samples": 10, **options})


def test_parse_orientations():
    assert reachmap.parse_orientations("200") == 200 and reachmap.parse_orientations("50X8") == (50, 8)
    with pytest.raises(ReachMapError, match="DIRxROLL"):
        reachmap.parse_orientations("0")



def test_a_tampered_map_is_refused_in_one_line_without_waiting(map_3r, tmp_path):
    import json
    import os

    path = tmp_path / "m.zarr"
    map_3r.save(path)
    meta_path = path / "zarr.json"
    meta = json.loads(meta_path.read_text())
    del meta["attributes"]["origin"]  # an attribute missing
    meta_path.write_text(json.dumps(meta))
    with pytest.raises(InputFileError, match="not a valid reachability map"):
        load(path)
    meta["attributes"]["origin"] = [0, 0, 0]
    meta["attributes"]["orientations"]["n_rolls"] = 400  # more bins than the stored array has
    meta_path.write_text(json.dumps(meta))
    with pytest.raises(InputFileError, match="array shapes that disagree with the attributes"):
        load(path)
    map_3r.save(path)
    os.mkfifo(path / "fifo")  # a stray entry: a map holds its own files only
    with pytest.raises(InputFileError, match="it holds fifo, which is not part of a reachability map"):
        load(path)
    os.remove(path / "fifo")
    chunk = path / "reach" / "c" / "0" / "0" / "0" / "0"
    chunk.unlink()
    os.mkfifo(chunk)  # reading a FIFO would wait forever
    with pytest.raises(InputFileError, match="reach/c/0/0/0/0 is not a regular file"):
        load(path)


def test_a_grid_too_large_for_memory_is_refused_before_anything_is_allocated(planar_2r):
    with pytest.raises(ReachMapError, match="more than 2147483648"):
        build(planar_2r, voxel=1e-5, orientations=1, samples=10)


def test_a_planar_map_with_one_bin_still_refuses_a_tilted_tool(planar_2r):
    # one orientation bin spans every heading, but a planar 2R's tool z stays along the base z: a pose tilted
    # out of the plane (by 90 deg, or flipped) is never reachable, whatever the bin width
    reach_map = build(planar_2r, voxel=0.1, orientations=1, samples=20000, method="fk", progress=False)
    T = np.eye(4)
    T[:3, 3] = [1.0, 0.0, 0.0]
    assert reach_map.query(T)
    for R in (rot_y(math.pi / 2), rot_y(math.pi)):
        T[:3, :3] = R
        assert not reach_map.query(T)
