"""PathPlan.feasibility, the data of the feasibility map (waypoint x tool angle), against the plan's own report.

An iiwa14 line pushed out along x until the arm stretches: with ``singular_tol`` the stretched waypoint's
candidates are near-singular, past it nothing reaches. The cells must agree with ``failures`` and
``first_failure`` (which the ladder computes its own way) and with the sampled tool angles. The path check is
loosened (``path_tol`` 10): at 1 mm and 1 deg every step from waypoint 0 to 1 fast enough leaves the path (least
worst point 1.04 x the tolerance over the 3513 allowed pairs, checked point by point by hand), so waypoint 1 would
die first and the stretched waypoint would not be reached.
"""

from __future__ import annotations

import numpy as np
import pytest

import manipkit
from manipkit.paths import line_poses, plan_path
from manipkit.paths.plan import FEASIBILITY_KINDS


@pytest.fixture(scope="module")
def stretched():
    chain = manipkit.load("iiwa14").chain("base_link", "ee_link")
    T0 = chain.fk([0.0, 0.6, 0.0, -1.2, 0.0, 0.9, 0.0])
    T1 = T0.copy()
    T1[0, 3] += 0.4
    return plan_path(chain, line_poses(T0, T1, step=0.05), speed=0.1, free_axis="z", free_step=np.radians(60),
                     arm_angle_step=np.radians(30), singular_tol=0.05, path_tol=10.0)


def test_cells_agree_with_first_failure_and_the_failures(stretched):
    plan = stretched
    kind = FEASIBILITY_KINDS.index
    cells = plan.feasibility
    assert cells.shape == (9, 6)  # 0.4 m at 5 cm: 9 waypoints; a full turn at 60 deg: 6 tool angles
    np.testing.assert_allclose(plan.free_angles, np.radians(-180 + 60 * np.arange(6)))
    assert not plan.feasible and plan.first_failure is not None
    alive = (cells >= kind("reached")).any(axis=1)
    assert alive[:plan.first_failure].all() and not alive[plan.first_failure:].any()
    for i, records in enumerate(plan.failures):
        kinds = {r.kind for r in records}
        # a waypoint whose every target sample is unreachable has only unreachable cells, and only there
        all_unreachable = any(r.kind == "unreachable" and r.count == plan.resolution["samples"] for r in records)
        assert all_unreachable == (cells[i] == kind("unreachable")).all()
        if (cells[i] == kind("near_singular")).any():
            assert "near_singular" in kinds
    assert (cells[plan.first_failure] == kind("near_singular")).all()


def test_a_feasible_plan_marks_one_chosen_angle_per_waypoint():
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    T0 = chain.fk([0.3, -1.2, 1.4, -1.8, -1.5, 0.2])
    T1 = T0.copy()
    T1[2, 3] += 0.05
    plan = plan_path(chain, line_poses(T0, T1, step=0.01), speed=0.05, free_axis="z", free_step=np.radians(90))
    chosen = plan.feasibility == FEASIBILITY_KINDS.index("chosen")
    assert plan.feasible and (chosen.sum(axis=1) == 1).all()
    np.testing.assert_allclose(plan.free_angles[np.argmax(chosen, axis=1)], plan.tool_angles)
    no_axis = plan_path(chain, line_poses(T0, T1, step=0.01), speed=0.05)
    assert no_axis.feasibility.shape == (6, 1) and (no_axis.feasibility == FEASIBILITY_KINDS.index("chosen")).all()
