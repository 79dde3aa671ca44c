"""The payload layer of a reach map (issue 37): best and worst capacity per voxel, built in blocks, resumable.

Independent sources: the planar 2R's capacity derived by hand below (the
torque is affine in the mass: ``m_max = min_j (limit_j - g_j(q)) / (dtau_j/dm)``,
with the gravity torques of its point masses written out), and
:func:`manipkit.statics.capacity.payload_capacity` called at each stored
configuration one voxel at a time (iiwa14), independently of the blocks,
the Dask runner and the per-voxel reduction; for the UR5 (a closed-form
family), every solution :func:`manipkit.ik` lists one pose at a time
(``all=True, aliases=False``), weighed by ``payload_capacity``, against the
layer's best and worst over branches. Local clusters are real
``distributed.LocalCluster``s, as the reach map's own tests start them.
"""

import json
import warnings

import numpy as np
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.analysis.reachmap import base_placement, build, capacity_at, confirm_placement, load, payload_map
from manipkit.analysis.reachmap.blockstore import ResumeNote
from manipkit.errors import InputFileError, ReachMapError
from manipkit.statics.capacity import payload_capacity

G = 9.81
GRAVITY_2R = (0.0, -G, 0.0)  # in the arm's plane (x-y), along -y of base_link
EFFORT_2R = np.array([18.0, 20.0])  # N m, symmetric: joint 1 cannot hold the arm stretched out level
COG_2R = (0.1, 0.05, 0.0)  # m, in ee_link's axes
MAP_2R = {"voxel": 0.25, "orientations": 8, "samples": 20_000, "holdout": 0, "fp_checks": 0}


def hand_capacity_2r(q: np.ndarray, effort=EFFORT_2R, cog=COG_2R) -> tuple[np.ndarray, np.ndarray]:
    """(m_max kg, saturating joint) of the planar 2R, derived by hand.

    Its URDF: 1 kg at the middle of each 1 m link and 1 g at the tip (ee_link's inertial).

    With gravity g along -y the potential is V = g sum m_i y_i, and a turn
    about z at the point (ox, oy) moves a point (x, y) by (-(y - oy), x - ox),
    so joint j holds tau_j = g sum_{i after j} m_i (x_i - ox_j). The CoMs are
    at x = 0.5 c1, c1 + 0.5 c12 and (the 1 g) c1 + c12; the payload at the tip (c1 + c12, s1 + s12)
    plus R(q1 + q2) (cx, cy): x_p = c1 + c12 + cx c12 - cy s12. Joint 2
    sits at x = c1. Torque per kg b_j = g (x_p - ox_j); torque unloaded a_j.
    """
    c1, c12, s12 = np.cos(q[:, 0]), np.cos(q[:, 0] + q[:, 1]), np.sin(q[:, 0] + q[:, 1])
    x1, x2, x_tip = 0.5 * c1, c1 + 0.5 * c12, c1 + c12
    xp = c1 + c12 + cog[0] * c12 - cog[1] * s12
    a = np.stack([G * (x1 + x2 + 0.001 * x_tip), G * (x2 - c1 + 0.001 * (x_tip - c1))], axis=1)
    b = np.stack([G * xp, G * (xp - c1)], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = np.where(b > 0, (effort - a) / b, (-effort - a) / b)
    bound = np.where(np.abs(b) > 1e-12, bound, np.inf)
    over = np.abs(a) > effort
    bound = np.where(over, 0.0, bound)
    return bound.min(axis=1), np.where(over.any(axis=1), np.argmax(over, axis=1), np.argmin(bound, axis=1))


@pytest.fixture(scope="module")
def map_2r(planar_2r):
    return build(planar_2r, **MAP_2R)


@pytest.fixture(scope="module")
def layer_2r(planar_2r, map_2r):
    return payload_map(map_2r, planar_2r, cog=COG_2R, gravity=GRAVITY_2R, effort=EFFORT_2R, block=100)


def test_the_planar_2r_capacity_matches_the_hand_derivation_at_every_voxel(map_2r, layer_2r):
    layer = layer_2r.payload
    hand, joint = hand_capacity_2r(map_2r.cert_q)
    assert 0 < (hand > 0).sum() < hand.size and np.isfinite(hand).all()  # some bins carry a load, some none
    np.testing.assert_allclose(layer.bins, hand, rtol=1e-10, atol=1e-10)
    voxels = map_2r.cert_keys // map_2r.orientations.size
    reached = np.zeros(np.prod(map_2r.shape), dtype=bool)
    reached[voxels] = True
    assert np.array_equal(~np.isnan(layer.best.reshape(-1)), reached)  # NaN exactly where nothing was reached
    checked_worst_joint = 0
    for v in np.unique(voxels):
        mine = voxels == v
        assert layer.best.reshape(-1)[v] == pytest.approx(hand[mine].max(), rel=1e-10, abs=1e-10)
        assert layer.worst.reshape(-1)[v] == pytest.approx(hand[mine].min(), rel=1e-10, abs=1e-10)
        if np.ptp(np.sort(hand[mine])[:2]) > 1e-6 or mine.sum() == 1:  # a unique worst: its joint is defined
            assert layer.saturating.reshape(-1)[v] == joint[mine][np.argmin(hand[mine])]
            checked_worst_joint += 1
    assert checked_worst_joint > 50 and set(np.unique(layer.saturating[layer.saturating >= 0])) == {0, 1}


def test_one_voxel_by_hand(planar_2r, map_2r, layer_2r):
    """The voxel at (1.5, 0.5): every stored configuration's capacity, and the voxel's best and worst."""
    (i, j, k), inside = map_2r.voxel_of([1.5, 0.5, 0.0])
    assert inside
    flat = np.ravel_multi_index((i, j, k), map_2r.shape)
    rows = np.flatnonzero(map_2r.cert_keys // map_2r.orientations.size == flat)
    assert rows.size >= 2
    q = map_2r.cert_q[rows]
    hand, _ = hand_capacity_2r(q)
    assert layer_2r.payload.best[i, j, k] == pytest.approx(hand.max(), rel=1e-10)
    assert layer_2r.payload.worst[i, j, k] == pytest.approx(hand.min(), rel=1e-10)
    T = planar_2r.fk(q, base="base_link", tip="ee_link")  # the pose of each configuration: its own voxel-bin
    np.testing.assert_allclose(capacity_at(layer_2r, T), hand, rtol=1e-10)


def test_every_voxel_of_an_iiwa14_map_against_payload_capacity_recomputed(iiwa14):
    reach_map = build(iiwa14, voxel=0.2, orientations=20, samples=20_000, holdout=0, fp_checks=0)
    cog = (0.02, -0.03, 0.08)
    layer = payload_map(reach_map, iiwa14, cog=cog, block=1000, branches=False).payload  # the stored ones alone
    voxels = reach_map.cert_keys // reach_map.orientations.size
    worst_joints = []
    for v in np.unique(voxels):
        cap = payload_capacity(iiwa14, reach_map.cert_q[voxels == v], cog=cog)  # one voxel at a time
        assert layer.best.reshape(-1)[v] == np.max(cap.max_mass)
        assert layer.worst.reshape(-1)[v] == np.min(cap.max_mass)
        worst_joints.append(int(cap.saturating[np.argmin(cap.max_mass)]))
        assert layer.saturating.reshape(-1)[v] == worst_joints[-1]
    assert 30.0 < np.nanmax(layer.best) < np.inf and len(set(worst_joints)) >= 2
    assert layer.joints == tuple(iiwa14.joint_names)


UR5_COG = (0.02, -0.03, 0.08)  # m, in ee_link's axes


@pytest.fixture(scope="module")
def ur5_maps(load_robot):
    """(robot, map, the layer over every closed-form branch, the layer of the stored configurations alone)."""
    ur5 = load_robot("ur5")
    reach_map = build(ur5, voxel=0.25, orientations=8, samples=20_000, holdout=0, fp_checks=0)
    return (ur5, reach_map, payload_map(reach_map, ur5, cog=UR5_COG, block=500),
            payload_map(reach_map, ur5, cog=UR5_COG, branches=False))


def test_the_ur5_layer_is_the_best_and_worst_over_every_closed_form_branch(ur5_maps):
    ur5, reach_map, every, stored = ur5_maps
    layer = every.payload
    assert layer.configurations == "branches" and stored.payload.configurations == "certificates"
    voxels = reach_map.cert_keys // reach_map.orientations.size
    counts = np.bincount(voxels)
    chosen = np.flatnonzero(counts >= 3)[::40][:6]  # a few voxels of several bins each
    assert len(chosen) >= 4
    saturating_checked = 0
    for v in chosen:
        caps, joints = [], []
        for q in reach_map.cert_q[voxels == v]:  # each bin's pose, every branch the dispatcher lists
            T = ur5.transform(reach_map.base, reach_map.frame, q)
            answer = manipkit.ik(ur5, T, base=reach_map.base, tip=reach_map.frame, all=True, aliases=False)
            assert answer.method == "closed_form"
            cap = payload_capacity(ur5, answer.solutions[answer.within_limits], cog=UR5_COG)
            caps.append(cap.max_mass)
            joints.append(cap.saturating)
        caps, joints = np.concatenate(caps), np.concatenate(joints)
        flat = np.unravel_index(v, reach_map.shape)
        assert layer.best[flat] == pytest.approx(caps.max(), rel=1e-9)
        assert layer.worst[flat] == pytest.approx(caps.min(), rel=1e-9)
        if np.ptp(np.sort(caps)[:2]) > 1e-6:  # a unique worst: its joint is defined
            assert layer.saturating[flat] == joints[np.argmin(caps)]
            saturating_checked += 1
    assert saturating_checked >= 2


def test_every_branch_widens_the_range_of_the_stored_configurations(ur5_maps, tmp_path):
    _, reach_map, every, stored = ur5_maps
    new, old = every.payload, stored.payload
    reached = ~np.isnan(old.best)
    assert np.array_equal(reached, ~np.isnan(new.best))
    assert np.all(new.best[reached] >= old.best[reached]) and np.all(new.worst[reached] <= old.worst[reached])
    assert np.mean(new.best[reached] > old.best[reached] * (1 + 1e-6)) > 0.3  # other branches do differ
    assert np.all(new.bins_worst <= old.bins) and np.all(old.bins <= new.bins)
    again = load(every.save(tmp_path / "ur5.zarr")).payload
    assert again.configurations == "branches" and again.bins_worst.tobytes() == new.bins_worst.tobytes()
    assert "branches: every closed-form branch" in every.payload_text()
    assert "branches: 1 per voxel-bin, its stored configuration" in stored.payload_text()


IIWA_COG = (0.02, -0.03, 0.08)  # m, in the tip frame's axes


def test_an_srs_arm_weighs_every_branch_at_the_stored_configuration_s_arm_angle(iiwa14, tmp_path):
    """The iiwa14 (7R SRS: its pose has a self-motion, its closed form needs an arm angle) with arm_angles=0: each
    bin's pose is solved at the stored configuration's own arm angle and every in-limit branch there (up to 8) is
    weighed. Recomputed here one bin at a time by manipkit.ik(all=True) at that
    angle and payload_capacity of each in-limit solution."""
    from manipkit.ik.chain_ik import srs_arm_angle

    reach_map = build(iiwa14, voxel=0.3, orientations=8, samples=5000, holdout=0, fp_checks=0)
    every = payload_map(reach_map, iiwa14, cog=IIWA_COG, block=300, arm_angles=0)
    layer, stored = every.payload, payload_map(reach_map, iiwa14, cog=IIWA_COG, branches=False).payload
    assert layer.configurations == "arm_angle_branches" and layer.attrs()["configurations"] == "arm_angle_branches"
    assert stored.configurations == "certificates"
    assert "at each voxel-bin's stored configuration's arm angle (not the whole self-motion)" in every.payload_text()
    chain = iiwa14.chain(reach_map.base, reach_map.frame)
    voxels = reach_map.cert_keys // reach_map.orientations.size
    chosen = np.flatnonzero(np.bincount(voxels) >= 2)[::7][:6]
    assert len(chosen) >= 4
    wider = 0
    for v in chosen:
        caps = []
        for q in reach_map.cert_q[voxels == v]:
            psi = srs_arm_angle(chain, q[chain.columns])
            T = iiwa14.transform(reach_map.base, reach_map.frame, q)
            answer = manipkit.ik(iiwa14, T, base=reach_map.base, tip=reach_map.frame, arm_angle=psi, all=True,
                                 aliases=False)
            assert answer.method == "closed_form" and len(answer.solutions) <= 8
            branch_caps = payload_capacity(iiwa14, answer.solutions[answer.within_limits], cog=IIWA_COG).max_mass
            own = float(payload_capacity(iiwa14, q, cog=IIWA_COG).max_mass)
            assert branch_caps.min() - 1e-9 <= own <= branch_caps.max() + 1e-9  # q is one of its branches
            caps.append(branch_caps)
            wider += int(len(branch_caps) > 1)
        caps = np.concatenate(caps)
        flat = np.unravel_index(v, reach_map.shape)
        assert layer.best[flat] == pytest.approx(caps.max(), rel=1e-9, abs=1e-9)
        assert layer.worst[flat] == pytest.approx(caps.min(), rel=1e-9, abs=1e-9)
    assert wider >= 4  # the bins checked do have other in-limit branches
    reached = ~np.isnan(stored.best)
    assert np.all(layer.best[reached] >= stored.best[reached]) and np.all(layer.worst[reached] <= stored.worst[reached])
    assert np.all(layer.bins_worst <= stored.bins) and np.all(stored.bins <= layer.bins)
    again = load(every.save(tmp_path / "iiwa14.zarr")).payload
    assert again.configurations == "arm_angle_branches" and again.bins.tobytes() == layer.bins.tobytes()


def test_one_worker_process_or_two_give_the_same_layer(planar_2r, map_2r, layer_2r):
    for workers in (1, 2):
        there = payload_map(map_2r, planar_2r, cog=COG_2R, gravity=GRAVITY_2R, effort=EFFORT_2R, block=100,
                            workers=workers).payload
        for name in ("best", "worst", "saturating", "bins"):
            assert getattr(there, name).tobytes() == getattr(layer_2r.payload, name).tobytes()


class Stop(Exception):
    """The interruption: raised from the progress callback after a block is saved."""


def test_an_interrupted_layer_resumes_to_the_same_arrays(planar_2r, map_2r, layer_2r, tmp_path):
    keep = tmp_path / "blocks"
    total = -(-len(map_2r.cert_q) // 100)

    def stop_after_three(stage, done, total):
        if done == 3:
            raise Stop

    options = {"cog": COG_2R, "gravity": GRAVITY_2R, "effort": EFFORT_2R, "block": 100, "resume_dir": keep}
    with pytest.raises(Stop):
        payload_map(map_2r, planar_2r, **options, progress=stop_after_three)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = payload_map(map_2r, planar_2r, **options).payload
    notes = [str(w.message) for w in caught if issubclass(w.category, ResumeNote)]
    assert notes == [f"resuming: 3 of {total} blocks of payload capacity already done"]
    for name in ("best", "worst", "saturating", "bins"):
        assert getattr(again, name).tobytes() == getattr(layer_2r.payload, name).tobytes()
    with warnings.catch_warnings(record=True) as caught:  # another CoG: another fingerprint, nothing reused
        warnings.simplefilter("always")
        payload_map(map_2r, planar_2r, **{**options, "cog": (0.0, 0.0, 0.0)})
    assert not [w for w in caught if issubclass(w.category, ResumeNote)]


def test_the_layer_is_saved_with_the_map_and_read_back_checked(map_2r, layer_2r, tmp_path):
    path = layer_2r.save(tmp_path / "m.zarr")
    again = load(path).payload
    for name in ("best", "worst", "saturating", "bins", "cog", "gravity", "lower", "upper"):
        assert getattr(again, name).tobytes() == getattr(layer_2r.payload, name).tobytes()
    assert again.joints == ("joint1", "joint2") and load(map_2r.save(tmp_path / "plain.zarr")).payload is None
    import zarr

    arrays = zarr.open_group(str(path), mode="r+")
    worst = arrays["payload_worst"][:]
    worst[np.isfinite(worst)] += 1.0  # a worst no stored configuration has
    arrays["payload_worst"][:] = worst
    with pytest.raises(InputFileError, match="payload_best and payload_worst are not"):
        load(path)
    import shutil

    broken = layer_2r.save(tmp_path / "b.zarr")
    shutil.rmtree(broken / "payload_bins")
    with pytest.raises(InputFileError, match="a payload layer needs its attribute and every one of its arrays"):
        load(broken)


def test_carrying_a_mass_counts_the_voxels_whose_best_capacity_holds_it(map_2r, layer_2r):
    layer = layer_2r.payload
    hand, _ = hand_capacity_2r(map_2r.cert_q)
    voxels = map_2r.cert_keys // map_2r.orientations.size
    mass = 5.0
    assert layer.carries(mass).sum() == np.unique(voxels[hand >= mass]).size > 0
    assert layer.carries_everywhere(mass).sum() == np.setdiff1d(np.unique(voxels), voxels[hand < mass]).size
    text = layer_2r.payload_text(mass)
    assert f"5 kg carried in {layer.carries(mass).sum()} of {np.unique(voxels).size} reachable voxels" in text
    assert "0.25 m voxels, 8 orientation bins" in text


def test_bad_input_is_refused_before_any_block(planar_2r, iiwa14, map_2r):
    with pytest.raises(ReachMapError, match="give the map's robot"):
        payload_map(map_2r, iiwa14)
    with pytest.raises(ReachMapError, match="cog"):
        payload_map(map_2r, planar_2r, cog=(0.0, float("nan"), 0.0))
    with pytest.raises(ReachMapError, match="block"):
        payload_map(map_2r, planar_2r, block=0)
    with pytest.raises(ReachMapError, match="no payload layer"):
        capacity_at(map_2r, np.eye(4))


def test_base_placement_counts_only_the_targets_whose_bin_holds_the_mass(planar_2r, map_2r, layer_2r):
    rows = np.arange(0, len(map_2r.cert_q), 7)
    targets = planar_2r.fk(map_2r.cert_q[rows], base="base_link", tip="ee_link")  # each in its own voxel-bin
    hand, _ = hand_capacity_2r(map_2r.cert_q[rows])
    mass = 2.0
    assert 0 < (hand >= mass).sum() < len(rows)
    xs, ys, yaws = [0.0, 10.0], [0.0], [0.0]  # 10 m away reaches nothing
    plain = base_placement(layer_2r, targets, xs=xs, ys=ys, yaws=yaws, threshold=0.0)
    loaded = base_placement(layer_2r, targets, xs=xs, ys=ys, yaws=yaws, threshold=0.0, payload=mass)
    assert plain.scores[:, 0, 0].tolist() == [len(rows), 0]
    assert loaded.scores[:, 0, 0].tolist() == [int((hand >= mass).sum()), 0]
    assert "carrying 2 kg" in loaded.summary()
    chosen = confirm_placement(layer_2r, loaded, planar_2r, candidates=1)
    assert chosen.payload == mass and 0 < chosen.confirmed.sum() <= len(rows)
    held, _ = hand_capacity_2r(chosen.q)  # IK's own configurations, by hand
    assert np.array_equal(chosen.confirmed, chosen.confirmed & (held >= mass))
    assert "holding 2 kg there" in chosen.summary()
    with pytest.raises(ReachMapError, match="no payload layer"):
        base_placement(map_2r, targets, xs=xs, ys=ys, yaws=yaws, payload=mass)


def test_the_command_line_builds_the_layer_and_says_where_it_carries_the_mass(planar_2r, tmp_path):
    path = tmp_path / "m.zarr"
    common = ("--robot", "planar_2r", "--voxel", "0.25", "--orientations", "8", "--samples", "20000")
    out = run_cli("manipkit", "reachmap", *common, "-o", path, "--payload", "0.5@0.1,0.05,0", "--gravity",
                  "0,-9.81,0", "--format", "json", status=0).stdout
    answer = json.loads(out)["payload"]
    saved = load(path)
    hand, _ = hand_capacity_2r(saved.cert_q, effort=np.array([10.0, 10.0]))  # the URDF's 10 N m limits
    voxels = saved.cert_keys // saved.orientations.size
    assert answer["voxels_carrying"] == np.unique(voxels[hand >= 0.5]).size > 0
    assert answer["reachable_voxels"] == np.unique(voxels).size and answer["mass"] == 0.5
    assert answer["cog"] == [0.1, 0.05, 0.0] and answer["gravity"] == [0.0, -9.81, 0.0]
    assert answer["configurations"] == "certificates"  # the planar 2R's map: no closed-form family
    assert answer["arm_angles"] == 0 and answer["arm_angle_step_rad"] is None  # and no self-motion sampled
    text = run_cli("manipkit", "reachmap", "show", path, "--payload", "0.5@0.1,0.05,0", status=0).stdout
    assert "branches: 1 per voxel-bin, its stored configuration" in text
    assert f"0.5 kg carried in {answer['voxels_carrying']} of {answer['reachable_voxels']} reachable voxels" in text
    other = run_cli("manipkit", "reachmap", "show", path, "--payload", "0.5", status=2)
    assert other.stderr.count("\n") == 1 and "payload layer for the CoG 0.1,0.05,0" in other.stderr
    bad = run_cli("manipkit", "reachmap", *common, "-o", tmp_path / "n.zarr", "--payload", "1@0,nan,0", status=2)
    assert bad.stderr.count("\n") == 1 and not (tmp_path / "n.zarr").exists()
    bad = run_cli("manipkit", "reachmap", *common, "-o", tmp_path / "a.zarr", "--payload", "1", "--arm-angles", "-1",
                  status=2)
    assert bad.stderr.count("\n") == 1 and "arm_angles -1" in bad.stderr and not (tmp_path / "a.zarr").exists()


def test_an_srs_arm_s_layer_ranges_over_sampled_arm_angles_of_its_self_motion(iiwa14, tmp_path):
    """The default iiwa14 layer ("self_motion") weighs every in-limit branch at the stored configuration's arm angle
    and at K = 4 arm angles -pi + 2 pi j / K: its best is at least the fixed-angle layer's, its worst at most, and
    both equal a brute force over the same angles here, one bin at a time by manipkit.ik(all=True, arm_angle=psi)
    and payload_capacity of each in-limit solution."""
    from manipkit.ik.chain_ik import srs_arm_angle

    K = 4
    reach_map = build(iiwa14, voxel=0.3, orientations=8, samples=5000, holdout=0, fp_checks=0)
    moving = payload_map(reach_map, iiwa14, cog=IIWA_COG, block=300, arm_angles=K)
    layer, fixed = moving.payload, payload_map(reach_map, iiwa14, cog=IIWA_COG, block=300, arm_angles=0).payload
    assert layer.configurations == "self_motion" and layer.arm_angles == K
    assert layer.attrs()["arm_angles"] == K and layer.attrs()["arm_angle_step_rad"] == pytest.approx(np.pi / 2)
    assert "at its stored configuration's arm angle and at 4 arm angles 90 deg apart" in moving.payload_text()
    reached = ~np.isnan(fixed.best)
    assert np.array_equal(reached, ~np.isnan(layer.best))
    assert np.all(layer.best[reached] >= fixed.best[reached]) and np.all(layer.worst[reached] <= fixed.worst[reached])
    assert np.all(layer.bins >= fixed.bins) and np.all(layer.bins_worst <= fixed.bins_worst)
    assert np.mean(layer.bins > fixed.bins * (1 + 1e-6)) > 0.2  # the self-motion does carry more
    chain = iiwa14.chain(reach_map.base, reach_map.frame)
    grid = [-np.pi + 2 * np.pi * j / K for j in range(K)]  # the samples, written out
    voxels = reach_map.cert_keys // reach_map.orientations.size
    chosen = np.flatnonzero(np.bincount(voxels) >= 2)[::7][:5]
    assert len(chosen) >= 4
    for v in chosen:
        caps = []
        for q in reach_map.cert_q[voxels == v]:
            T = iiwa14.transform(reach_map.base, reach_map.frame, q)
            caps.append(np.atleast_1d(payload_capacity(iiwa14, q, cog=IIWA_COG).max_mass))  # the stored one
            for psi in [srs_arm_angle(chain, q[chain.columns]), *grid]:
                answer = manipkit.ik(iiwa14, T, base=reach_map.base, tip=reach_map.frame, arm_angle=psi, all=True,
                                     aliases=False)
                inside = answer.solutions[answer.within_limits] if len(answer.solutions) else np.zeros((0, 7))
                if len(inside):
                    caps.append(np.atleast_1d(payload_capacity(iiwa14, inside, cog=IIWA_COG).max_mass))
        caps = np.concatenate(caps)
        flat = np.unravel_index(v, reach_map.shape)
        assert layer.best[flat] == pytest.approx(caps.max(), rel=1e-9, abs=1e-9)
        assert layer.worst[flat] == pytest.approx(caps.min(), rel=1e-9, abs=1e-9)
    again = load(moving.save(tmp_path / "iiwa14.zarr")).payload
    assert again.configurations == "self_motion" and again.arm_angles == K
    assert again.bins.tobytes() == layer.bins.tobytes()
    with pytest.raises(ReachMapError, match="arm_angles"):
        payload_map(reach_map, iiwa14, cog=IIWA_COG, arm_angles=-1)
