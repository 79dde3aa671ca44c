"""``manipkit family`` and the geometric closed forms through ``manipkit ik --analytic`` / ``--all`` (in process)."""

import json

import numpy as np
from cli_helper import run_cli

import manipkit


def test_family_prints_the_kind_and_the_evidence():
    result = run_cli("manipkit", "family", "--robot", "ur5", "--tip", "tool0", status=0)
    assert "family: three parallel, two intersecting" in result.stdout
    assert "axes 2, 3, 4 parallel, angle 0 rad" in result.stdout and "axes 5, 6 meet at" in result.stdout
    assert "manipkit ik --analytic --robot ur5 --base base_link --tip tool0" in result.stdout


def test_family_json_and_a_chain_without_one():
    out = json.loads(run_cli("manipkit", "family", "--robot", "kinova", "--base", "base", "--format", "json",
                             status=0).stdout)
    assert out["family"] == "spherical wrist, two parallel" and out["solved"]
    assert [e["axes"] for e in out["evidence"]] == [[4, 5, 6], [2, 3]]
    none = run_cli("manipkit", "family", "--robot", "xarm7", status=0)
    assert "family: none" in none.stdout and "7 joint(s)" in none.stdout


def target_args(T):
    from manipkit.spatial.rotations import rpy_from_matrix

    return ["--xyz", *(repr(float(v)) for v in T[:3, 3]), "--rpy", *(repr(float(v)) for v in rpy_from_matrix(T[:3, :3]))]


def test_ik_all_uses_the_closed_form_and_lists_every_branch():
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    T = chain.fk([0.3, -1.1, 1.2, -0.8, 1.0, 0.4])
    result = run_cli("manipkit", "ik", "--robot", "ur5", "--frame", "tool0", *target_args(T), "--all", "--no-aliases",
                     status=0)
    assert "closed form (three parallel, two intersecting, frame tool0 in base_link): 8 solution(s)\n" in result.stdout
    assert "1. [front, elbow up, no flip]" in result.stdout and "8. [back, elbow down, wrist flip]" in result.stdout
    assert "alias" not in result.stdout.split("note:")[0]


def test_ik_analytic_json_gives_limits_and_refinement_per_branch_from_a_base_below_the_root():
    robot = manipkit.load("kinova")
    chain = robot.chain("base", "j2s6s200_end_effector")
    q = np.array([0.3, 3.0, 1.5, 0.5, 1.0, 0.4])
    T = chain.fk(q)
    out = json.loads(run_cli("manipkit", "ik", "--robot", "kinova", "--base", "base", "--frame",
                             "j2s6s200_end_effector", *target_args(T), "--analytic", "--format", "json", status=0).stdout)
    assert out["method"] == "closed_form" and out["count"] == len(out["solutions"]) == len(out["within_limits"])
    assert out["within_limits"] == chain.within_limits(
        np.array([[s[name] for name in chain.joint_names] for s in out["solutions"]])).tolist()
    assert out["residual_position"] < 1e-9 and out["refined"] == [0.0] * len(out["solutions"])


def test_family_of_the_kinova_says_why_it_has_no_opw_parameters():
    out = json.loads(run_cli("manipkit", "family", "--robot", "kinova", "--base", "base", "--format", "json",
                             status=0).stdout)
    assert out["opw"] is None and "the tool frame's z axis is not axis 6" in out["opw_note"]


def test_ik_analytic_with_a_locked_joint_solves_a_7r_arm():
    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    q = np.array([0.3, 0.5, 0.4, -1.2, 0.3, 0.8, 0.2])
    out = json.loads(run_cli("manipkit", "ik", "--robot", "iiwa14", *target_args(chain.fk(q)), "--analytic",
                             "--lock", "iiwa_joint_3=0.4", "--format", "json", status=0).stdout)
    assert out["count"] == len(out["solutions"]) >= 1
    assert all(s["iiwa_joint_3"] == 0.4 for s in out["solutions"]) and out["residual_position"] < 1e-9
    family = run_cli("manipkit", "family", "--robot", "iiwa14", "--lock", "iiwa_joint_3=0.4", status=0)
    assert "family: spherical wrist, two intersecting" in family.stdout and "--lock iiwa_joint_3=0.4" in family.stdout


def test_ik_analytic_at_an_arm_angle_solves_the_iiwa14():
    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    T = chain.fk([0.3, 0.5, 0.4, -1.2, 0.3, 0.8, 0.2])
    result = run_cli("manipkit", "ik", "--robot", "iiwa14", *target_args(T), "--analytic", "--arm-angle", "0.5", status=0)
    assert "closed form (spherical shoulder, elbow, spherical wrist, frame ee_link in base_link)" in result.stdout
    assert "at arm angle psi = 0.5 rad" in result.stdout
