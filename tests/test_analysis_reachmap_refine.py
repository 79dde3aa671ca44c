"""The refined answer of a reach map (IK in the boundary band), against IK labels independent of the map.

Independent sources:

- Labels of random iiwa14 poses by numerical IK of the exact pose (``ik_many``,
  position+axis, 50 random restarts, success by FK to 1e-9), which never reads
  the map. A label can be wrong one way only: IK missing a solution calls a
  reachable pose unreachable. On the 20,000-pose measurement behind this test
  (CHANGELOG, docs/site/guides/reach-maps.md), 1000 restarts and the iiwa14's
  closed form at 360 arm angles x 2 rolls found no solution for any of the
  442 unreachable-labelled poses in reached voxel-bins nor for 300 others.
- A hand case: the iiwa14 stretched straight up (q = 0) and 1 cm past it,
  where the wrist centre lies 0.83 m from the shoulder, beyond the
  0.42 + 0.40 m of the upper arm and forearm.
"""

import dataclasses

import numpy as np
import pytest

from benchmarks.reachmap_workload import _random_rotations
from manipkit.analysis.reachmap import build
from manipkit.analysis.reachmap.query import UnrefinedWarning, answer_text, support_score
from manipkit.ik.numerical_many import ik_many

SEED, N_RANDOM, N_FK = 11, 2400, 400


@pytest.fixture(scope="module")
def map_iiwa(iiwa14):
    # coarser than the command line's 0.05 m and 200 directions (the measurement in the CHANGELOG is of that map):
    # 0.1 m voxels and 50 approach directions (any roll), sampled until a block adds under 0.1 % new voxel-bins
    return build(iiwa14, voxel=0.1, orientations=50, samples=20_000_000, converge=1e-3, manipulability=False,
                 holdout=2000, fp_checks=20)


@pytest.fixture(scope="module")
def labelled(iiwa14, map_iiwa):
    rng = np.random.default_rng(SEED)
    low, high = map_iiwa.origin, map_iiwa.origin + (np.array(map_iiwa.shape) - 1) * map_iiwa.voxel
    T = np.tile(np.eye(4), (N_RANDOM, 1, 1))
    T[:, :3, :3] = _random_rotations(N_RANDOM, rng)
    T[:, :3, 3] = low + rng.random((N_RANDOM, 3)) * (high - low)
    truth = np.asarray(ik_many(iiwa14, T, mode="position+axis", restarts=50, tol=1e-9, seed=7).success, dtype=bool)
    return T, truth


def test_refined_yes_is_rarely_wrong_and_misses_little(iiwa14, map_iiwa, labelled):
    T, truth = labelled
    plain, refined = map_iiwa.query(T, refine=False), map_iiwa.query(T, robot=iiwa14)
    unreachable = ~truth
    assert unreachable.sum() > 1500 and truth.sum() > 150  # about 13 % of random poses in the box are reachable
    false_yes, recall = (refined & unreachable).sum() / unreachable.sum(), refined[truth].mean()
    # Measured (seed 11, 2400 poses, 2173 labelled unreachable, 227 reachable): refined 15 false yes (0.69 %), recall
    # 227 of 227; the plain answer (support >= 0.65) 74 false yes (3.4 %), recall 227 of 227
    assert false_yes <= 0.01 and recall >= 0.98
    assert (plain & unreachable).sum() > (refined & unreachable).sum()
    # recall on FK poses of random configurations (reachable by construction, a stream the build never drew)
    T_fk = iiwa14.fk(iiwa14.sample_q(N_FK, seed=99), base="base_link", tip="ee_link")
    assert map_iiwa.query(T_fk, robot=iiwa14).mean() >= 0.98


def test_the_default_answer_is_the_refined_one_where_the_robot_loads(iiwa14, map_iiwa, labelled):
    T, truth = labelled
    assert map_iiwa.robot == "iiwa14"  # a bundled name: the default answer loads it and refines
    default = map_iiwa.query(T)  # no robot passed
    assert np.array_equal(default, map_iiwa.query(T, robot=iiwa14))
    unreachable = ~truth
    assert (default & unreachable).sum() / unreachable.sum() <= 0.01 and default[truth].mean() >= 0.98
    answer = map_iiwa.query(T, detail=True)
    assert np.array_equal(answer.reachable, default) and answer.unrefined_because == ""
    band = (answer.score > 0.0) & (answer.score < 1.0)
    assert np.array_equal(answer.decided_by_ik, band) and band.sum() > 20
    assert answer_text(map_iiwa, answer).startswith(f"decided by IK near the boundary: {band.sum()} of {len(T)} poses")
    # the map's own rule, asked for: unrefined (support >= threshold, or the voxel-bin alone)
    plain = map_iiwa.query(T, refine=False)
    assert np.array_equal(map_iiwa.query(T, threshold=0.65), plain) and (plain & unreachable).sum() > (
        default & unreachable).sum()
    assert map_iiwa.query(T, detail=True, refine=False).decided_by_ik is None


@pytest.mark.parametrize("change", [{"robot": "no_such_robot_38"}, {"robot": "/nonexistent/arm_38.urdf"}, "shuffled"])
def test_a_map_whose_robot_does_not_load_gives_its_unrefined_estimate_and_says_so(map_iiwa, labelled, change):
    T, _ = labelled
    # an unknown name; a file path (a map's is never read); the iiwa14 by name, but FK of it does not put the
    # map's certificates in their voxel-bins (here: certificates shuffled), as with another robot of that name
    change = {"cert_q": map_iiwa.cert_q[::-1].copy()} if change == "shuffled" else change
    elsewhere = dataclasses.replace(map_iiwa, **change)
    with pytest.warns(UnrefinedWarning, match=r"the map's unrefined estimate, not decided by IK .*measured error: "
                      r"completeness: of a held-out sample of 2000 reachable poses"):
        said = elsewhere.query(T[:200])
    assert np.array_equal(said, map_iiwa.query(T[:200], refine=False))
    with pytest.warns(UnrefinedWarning):
        answer = elsewhere.query(T[:200], detail=True)
    assert answer.decided_by_ik is None and "did not load by its name" in answer_text(elsewhere, answer)


def test_refinement_changes_only_the_boundary_band(iiwa14, map_iiwa, labelled):
    T, _ = labelled
    answer = map_iiwa.query(T, detail=True)
    refined = map_iiwa.query(T, detail=True, robot=iiwa14)
    outside = (answer.score == 0.0) | (answer.score == 1.0)
    assert np.array_equal(refined.reachable[outside], answer.reachable[outside])
    assert np.array_equal(refined.bin_reached, answer.bin_reached)
    assert np.array_equal(map_iiwa.query(T, robot=iiwa14, refine=False), map_iiwa.query(T, refine=False))
    # every yes in the band is a pose IK reaches (labels from 50 random restarts, independent of the map)
    band = ~outside & refined.reachable
    again = ik_many(iiwa14, T[band], mode="position+axis", restarts=200, tol=1e-9, seed=3)
    assert band.sum() > 20 and np.asarray(again.success).all()


def test_hand_case_straight_up(iiwa14, map_iiwa):
    T_up = iiwa14.fk(np.zeros((1, 7)), base="base_link", tip="ee_link")[0]
    shoulder = iiwa14.transform("base_link", "iiwa_link_2", np.zeros(7))[:3, 3]
    wrist = iiwa14.transform("base_link", "iiwa_link_6", np.zeros(7))[:3, 3]
    assert np.linalg.norm(wrist - shoulder) == pytest.approx(0.42 + 0.40, abs=1e-12)  # stretched: 0.82 m
    above = T_up.copy()
    above[2, 3] += 0.01  # same axis (up), 1 cm higher: the wrist 0.83 m from the shoulder, out of reach
    score = support_score(map_iiwa, np.stack([T_up, above])[:, :3, 3],
                          map_iiwa.orientations.bin_of(np.stack([T_up, above])[:, :3, :3]))
    assert 0.0 < score[1] < 1.0  # in the boundary band: decided by IK
    assert map_iiwa.query(T_up, robot=iiwa14) is True and map_iiwa.query(above, robot=iiwa14) is False
    # numerical IK with many restarts agrees with the hand derivation: no configuration reaches ``above``
    assert not np.asarray(ik_many(iiwa14, above[None], mode="position+axis", restarts=200, tol=1e-9).success).any()


def dexterous_share(reach_map):
    """Share of voxels centred in 3.1 <= r <= 4.9 (a voxel inside the planar 3R's dexterous annulus 3 <= r <= 5,
    derived in test_analysis_reachmap.py) that the map marks dexterous (every turn reached)."""
    centres = reach_map.centers()[:, :, 0]
    r = np.hypot(centres[..., 0], centres[..., 1])
    inner = (r >= 3.1) & (r <= 4.9)
    return reach_map.dexterous[:, :, 0][inner].mean()


def test_a_planar_map_is_hybrid_by_default_and_marks_the_dexterous_annulus(planar_3r):
    options = dict(voxel=0.1, samples=1_000_000, converge=1e-4, manipulability=False, holdout=2000, fp_checks=20)
    default, sampled = build(planar_3r, **options), build(planar_3r, method="fk", **options)
    assert default.method == "hybrid" and sampled.method == "fk"
    # Measured: hybrid 99.85 %, fk 0.7 % at 1 M samples (every one of a voxel's 36 turns must be sampled); the
    # command line's fk defaults (4.26 M samples to converge 1e-4) marked 4472 of 4528 voxels (98.8 %), hybrid all
    assert dexterous_share(default) >= 0.995 > dexterous_share(sampled)
