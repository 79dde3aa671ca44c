"""One rule names a closed-form branch (manipkit.ik.branch_names): the single call and the batch agree.

A 7R arm with one joint locked (``lock=``) is solved as the 6R arm of the others; ``manipkit.ik(..., all=True)``
labels its rows and ``manipkit.ik_many(...).branch_labels(i)`` names target i's slots. For the Panda and the
iiwa14 at several locks and poses, the two maps label -> row are the same (rows to 1e-9), the labels of one answer
are distinct, every labelled row lands on the target by Pinocchio's own FK (``pin.forwardKinematics``) to 1e-10
and holds the locked value, and rows that share their words (numbered ``#1``, ``#2``) are distinct solutions.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import manipkit
from manipkit.ik.branch_names import numbered

#: (robot, locked joint): every lock of the two arms whose locked 6R arm has a closed form (iiwa14: not the
#: elbow, joint 4), both reading directions.
LOCKS = [("panda", "panda_joint6"), ("panda", "panda_joint7"), ("iiwa14", "iiwa_joint_1"),
         ("iiwa14", "iiwa_joint_3"), ("iiwa14", "iiwa_joint_5"), ("iiwa14", "iiwa_joint_7")]
POSES = 6


def pinocchio_pose(robot, q):
    model, data = robot.model, robot.model.createData()
    pin.forwardKinematics(model, data, robot.pinocchio_configuration(q))
    pin.updateFramePlacements(model, data)
    placement = lambda name: data.oMf[model.getFrameId(robot.frame(name))].homogeneous  # noqa: E731
    return np.linalg.inv(placement("base_link")) @ placement("ee_link")


@pytest.mark.parametrize(("name", "joint"), LOCKS)
def test_the_single_call_and_the_batch_name_each_branch_alike(name, joint):
    robot = manipkit.load(name)
    chain = robot.chain("base_link", "ee_link")
    columns = [robot.joint_names.index(j) for j in chain.joint_names]
    k = chain.joint_names.index(joint)
    for q in chain.sample(POSES, seed=11):
        T = pinocchio_pose(robot, chain.full(q))
        lock = {joint: float(q[k])}
        single = manipkit.ik(robot, T, all=True, lock=lock, aliases=False)
        assert single.method == "closed_form" and len(single.solutions) >= 2, single.note
        labels = single.labels
        assert len(set(labels)) == len(labels) and all(labels), labels  # distinct, none empty
        batch = manipkit.ik_many(robot, T[None], lock=lock)
        names = batch.branch_labels(0)
        named = {label: row for label, row in zip(names, batch.solutions[0]) if label}
        assert len(named) == sum(1 for label in names if label)  # distinct in the batch too
        assert set(named) == set(labels)
        for label, row in zip(labels, single.solutions):
            chain_row = row[columns]
            assert np.abs(named[label] - chain_row).max() < 1e-9, label
            assert chain_row[k] == lock[joint]
            assert np.abs(pinocchio_pose(robot, row) - T).max() < 1e-10, label
        rows = single.solutions[:, columns]
        for i, a in enumerate(labels):  # rows numbered apart are distinct solutions, not one row twice
            for j in range(i):
                assert np.abs(rows[i] - rows[j]).max() > 1e-6, (labels[j], a)


def test_the_iiwa_with_its_last_joint_locked_numbers_the_branches_that_share_their_words():
    # the locked 6R arm's "elbow" point lies on its axis 2: every branch reads "elbow up", two per description
    iiwa = manipkit.load("iiwa14")
    chain = iiwa.chain("base_link", "ee_link")
    q = chain.sample(1, seed=3)[0]
    answer = manipkit.ik(iiwa, chain.fk(q), all=True, lock={"iiwa_joint_7": float(q[6])}, aliases=False)
    assert len(answer.solutions) == 8
    assert sum(label.endswith(" #1") for label in answer.labels) == 4
    assert sum(label.endswith(" #2") for label in answer.labels) == 4


def test_numbering_leaves_distinct_words_alone_and_numbers_shared_ones_in_order():
    assert numbered(["a", "b"]) == ("a", "b")
    assert numbered(["a", "b", "a", "a"]) == ("a #1", "b", "a #2", "a #3")
    assert numbered([]) == ()


def test_a_batch_without_branch_names_gives_its_slot_labels():
    ur5 = manipkit.load("ur5")
    chain = ur5.chain("base_link", "tool0")
    batch = manipkit.ik_many(chain, chain.fk(chain.sample(2, seed=1)), method="numerical")
    assert batch.branch_labels(1) == batch.labels == ("",)
