"""manipkit.ik.result: one IK result type for every solver, one batch type, one tolerance parser.

Every solver, numerical or closed form, one target or all solutions, answers
with the same class, and the batches share its field names. The numbers in
those answers are checked in the tests of each solver (against Pinocchio,
DH tables and hand formulas); here, that the answers are one type with one
meaning: ``reason`` is ``""`` exactly on success, ``q`` is the first solution,
the residuals are those of each row's forward kinematics, and the arrays
cannot be written to.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import manipkit
from manipkit.bounds import tolerances
from manipkit.errors import ClosedFormIKError, IKOptionError, PlanarArmError
from manipkit.ik import decoupled, planar, planar_modes
from manipkit.ik.numerical import ik
from manipkit.ik.numerical_many import ik_many
from manipkit.ik.result import MODES, IKBatch, IKResult
from manipkit.ik.textbook import analytic_ik

BATCH_FIELDS = ("solutions", "labels", "count", "success", "residual_position", "residual_rotation", "residuals", "q",
                "q_residuals", "mode", "solver", "joint_names", "outside_by", "iterations", "attempts")


@pytest.fixture(scope="module")
def elbow(load_robot):
    return load_robot("elbow_arm")


def every_kind_of_answer(robot):
    """(name, answer) from each solver kind, for a target of the elbow arm (which every one of them can solve)."""
    T = robot.transform("base_link", "ee_link", [0.5, 0.4, -1.0, 0.3, 0.9, 0.2])
    return [
        ("ik", ik(robot, T)),
        ("ik(all=True)", ik(robot, T, all=True, restarts=3)),
        ("analytic_ik", analytic_ik(robot, T)),
        ("ik_elbow", decoupled.ik_elbow(T)),
        ("ik_2r", planar.ik_2r(0.0, 1.5, 1.0, 1.0)),
        ("ik_3r", planar.ik_3r(3.0, 2.0, math.pi, 4.0, 2.0, 1.0)),
        ("ik_2r_pose", planar_modes.ik_2r_pose(1.0, 1.0, math.pi / 2, 1.0, 1.0)),
        ("ik_3r_position", planar_modes.ik_3r_position(4.0, 2.0, 4.0, 2.0, 1.0)),
    ]


def test_every_solver_answers_with_the_one_class(elbow):
    for name, answer in every_kind_of_answer(elbow):
        assert type(answer) is IKResult, name
    assert not hasattr(manipkit.ik.numerical, "IKSolutions")  # numerical IK's 0.1 alias is gone
    assert manipkit.IKResult is IKResult and manipkit.IKBatch is IKBatch


def test_every_answer_has_the_same_meaning(elbow):
    for name, answer in every_kind_of_answer(elbow):
        k = answer.solutions.shape[0]
        assert answer.success and answer.reason == "" and answer.mode in MODES, name
        assert len(answer.labels) == k and answer.residuals.shape == (k, 2), name
        assert answer.count == k or (answer.infinite and answer.free_parameter), name
        assert np.array_equal(answer.q, answer.solutions[0]) and np.array_equal(answer.q_residuals, answer.residuals[0])
        assert np.all(answer.residuals <= 1e-9), name
        for array in (answer.solutions, answer.residual_position, answer.residual_rotation):
            assert not array.flags.writeable, name


def test_no_solution_means_an_empty_result_with_a_reason(elbow):
    closed = planar.ik_2r(3.0, 0.0, 1.0, 1.0)
    far = np.eye(4)
    far[0, 3] = 5.0
    numerical = ik(elbow, far, restarts=1)
    for answer in (closed, numerical):
        assert not answer.success and answer.count == 0 and answer.solutions.shape[0] == 0
        assert answer.reason == answer.note and answer.reason.startswith(("no solution", "target out of reach"))
        assert answer.unmet and answer.unmet[0][0] == "position" and answer.outside_by > 0.0
    # a closed form has no configuration to offer; a numerical search the closest it found, with its residuals
    assert closed.q is None and closed.q_residuals is None and closed.closest is None
    assert numerical.q is None and numerical.q_residuals is None  # q means the same for every method
    assert numerical.closest is not None and numerical.closest_residuals.shape == (2,)


def test_a_result_cannot_be_changed():
    answer = planar.ik_2r(0.0, 1.5, 1.0, 1.0)
    with pytest.raises(AttributeError):
        answer.count = 3
    with pytest.raises(ValueError):
        answer.solutions[0, 0] = 1.0
    mutable = np.zeros((1, 2))
    copied = IKResult(mutable, ("",), 1, "", np.zeros(1), np.zeros(1))
    mutable[0, 0] = 7.0  # the result keeps its own read-only copy
    assert copied.solutions[0, 0] == 0.0 and not copied.solutions.flags.writeable


def test_a_result_of_checked_rows_equals_the_constructors_and_cannot_be_changed():
    """IKResult.of_checked_rows (the compiled single calls' constructor, no copies) gives the result the
    constructor gives from the same arrays, field for field, every array read-only; writable arrays are refused."""
    block = np.arange(24, dtype=float).reshape(3, 8)  # a kernel's answer: rows, residuals, within, code
    block.setflags(write=False)
    within = block[:, 3] > 10.0
    within.setflags(write=False)
    refined = np.zeros(3)
    refined.setflags(write=False)
    args = (block[:, :3], ("a", "b", "c"), "note", block[:, 4], block[:, 5], within, refined)
    fast = IKResult.of_checked_rows(*args, mode=MODES[3], solver="s", joint_names=("j1", "j2", "j3"))
    normal = IKResult(args[0], args[1], 3, args[2], args[3], args[4], mode=MODES[3], solver="s",
                      joint_names=("j1", "j2", "j3"), within_limits=within, refined=refined)
    for name in IKResult.__dataclass_fields__:
        a, b = getattr(fast, name), getattr(normal, name)
        if isinstance(a, np.ndarray):
            assert isinstance(b, np.ndarray) and a.dtype == b.dtype and np.array_equal(a, b) and not a.flags.writeable
        else:
            assert a == b, name
    assert fast.success and fast.q_residuals.tolist() == normal.q_residuals.tolist() and repr(fast) == repr(normal)
    algebraic = IKResult.of_checked_rows(*args, mode=MODES[3], solver="s", joint_names=("j1", "j2", "j3"),
                                         method="algebraic", rejected=2, arm_family="general 6R")
    assert (algebraic.method, algebraic.rejected, algebraic.arm_family) == ("algebraic", 2, "general 6R")
    with pytest.raises(ValueError, match="a method of"):
        IKResult.of_checked_rows(*args, mode=MODES[3], solver="s", joint_names=(), method="guessed")
    with pytest.raises(AttributeError):
        fast.count = 2
    with pytest.raises(ValueError):
        fast.solutions[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        IKResult.of_checked_rows(np.zeros((3, 3)), *args[1:], mode=MODES[3], solver="s", joint_names=())
    with pytest.raises(ValueError, match="within_limits of bool"):
        IKResult.of_checked_rows(*args[:5], refined, refined, mode=MODES[3], solver="s", joint_names=())


def _same_fields(a, b) -> None:
    for name in IKResult.__dataclass_fields__:
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray):
            assert isinstance(y, np.ndarray) and x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True), name
            assert not x.flags.writeable, name
        else:
            assert x == y, name


@pytest.mark.parametrize("changes", [
    {"solver": "other"},
    {"note": "n", "count": 7},
    {"solutions": np.zeros((0, 3)), "labels": (), "residual_position": np.zeros(0), "residual_rotation": np.zeros(0),
     "within_limits": np.zeros(0, dtype=bool), "refined": np.zeros(0)},  # no rows: the failure is derived again
    {"alias_of": [-1, 0, 0], "within_limits": [1, 0, 1]},  # lists and ints: copied into read-only typed arrays
    {"solutions": np.ones((3, 3)), "scores": np.arange(3.0)},  # writable arrays: copied, read-only
])
def test_replaced_is_dataclasses_replace(changes):
    """IKResult.replaced(**changes) (the fast form every IK module uses) is dataclasses.replace(result, **changes),
    field for field (the failure derived from the fields again where it is derived); an unknown name is a
    TypeError, as replace raises."""
    from dataclasses import replace

    block = np.arange(9, dtype=float).reshape(3, 3)
    result = IKResult(block, ("a", "b", "c"), 3, "note", np.zeros(3), np.zeros(3), mode=MODES[3], solver="s",
                      joint_names=("j1", "j2", "j3"), within_limits=np.ones(3, dtype=bool), refined=np.zeros(3))
    fast, slow = result.replaced(**changes), replace(result, **changes)
    _same_fields(fast, slow)
    assert type(fast) is IKResult and fast.reason == slow.reason and repr(fast) == repr(slow)
    assert result.solutions is block or np.array_equal(result.solutions, block)  # the original is not changed
    with pytest.raises(TypeError, match="no field 'colour'"):
        result.replaced(colour="red")
    with pytest.raises(TypeError):
        replace(result, colour="red")


def test_members_of_a_result_that_is_no_family_is_an_error():
    with pytest.raises(ClosedFormIKError, match="not a family"):
        planar.ik_2r(1.0, 1.0, 1.0, 1.0).members([0.0])


def test_repr_is_one_line_for_humans():
    text = repr(planar.ik_2r(0.0, 1.5, 1.0, 1.0))
    assert text.startswith("IKResult(method='closed_form', solver='planar.ik_2r', mode='planar position (x, y)', count=2, success=True, "
                           "q=[0.848062, 1.44547], residual=(") and text.endswith(" m, 0 rad))") and "\n" not in text
    missed = repr(planar.ik_2r(3.0, 0.0, 1.0, 1.0))
    assert "success=False" in missed and "reason='no solution: target too far" in missed and "q=" not in missed


# --------------------------------------------------------------------------
# batches: the same field names, with leading target axes


def test_batch_results_share_the_field_names_of_the_one_result(load_robot):
    robot = load_robot("course_arm")
    T = robot.fk(robot.sample_q(3, seed=1), base="base_link", tip="ee_link")
    batches = [ik_many(robot, T, mode="position+axis"), planar.ik_2r_batch([[1.0, 1.0], [3.0, 0.0]], 1.0, 1.0),
               planar.ik_3r_batch([[3.0, 2.0, math.pi]], 4.0, 2.0, 1.0)]
    for batch in batches:
        assert type(batch) is IKBatch
        for name in BATCH_FIELDS:
            assert hasattr(IKResult, name) or name in IKResult.__dataclass_fields__, name
            getattr(batch, name)  # every field answers
        n_targets, k, n = batch.solutions.shape
        assert batch.count.shape == batch.success.shape == (n_targets,) and batch.q.shape == (n_targets, n)
        assert batch.residual_position.shape == batch.residual_rotation.shape == (n_targets, k)
        assert batch.residuals.shape == (n_targets, k, 2) and batch.q_residuals.shape == (n_targets, 2)
        assert len(batch.labels) == k and batch.mode in MODES and len(batch) == n_targets
        with pytest.raises(AttributeError):
            batch.count = None
        with pytest.raises(ValueError):
            batch.solutions[0, 0, 0] = 1.0


def test_a_batch_row_says_what_the_single_solver_says():
    targets = [[0.0, 1.5], [2.0, 0.0], [3.0, 0.0], [0.0, 0.0]]
    batch = planar.ik_2r_batch(targets, 1.0, 1.0)
    for i, target in enumerate(targets):
        single = planar.ik_2r(*target, 1.0, 1.0)
        k = single.solutions.shape[0]
        assert batch.success[i] == single.success and batch.count[i] == single.count
        assert np.array_equal(batch.solutions[i, :k], single.solutions)
        np.testing.assert_allclose(batch.residuals[i, :k], single.residuals, atol=1e-15)
        if single.success:
            assert np.array_equal(batch.q[i], single.q)
        else:
            assert np.isnan(batch.q[i]).all() and np.isnan(batch.q_residuals[i]).all()


# --------------------------------------------------------------------------
# the one tolerance parser


@pytest.mark.parametrize(("tol", "expected"), [(1e-9, (1e-9, 1e-9)), (2, (2.0, 2.0)), ((1e-6, 1e-3), (1e-6, 1e-3)),
                                                (np.array([1e-6]), (1e-6, 1e-6)), ([1e-4, 1e-5], (1e-4, 1e-5))])
def test_tolerances_take_one_number_or_a_pair(tol, expected):
    assert tolerances(tol) == expected


@pytest.mark.parametrize("tol", [0.0, -1.0, math.nan, math.inf, (1e-6, 0.0), (1, 2, 3), "tight", [[1e-6]], None])
def test_tolerances_refuse_what_is_not_a_positive_number_or_pair(tol):
    with pytest.raises(IKOptionError, match="tol must be a positive number or \\(position m, rotation rad\\)"):
        tolerances(tol)


def test_tolerances_take_the_callers_error_and_rules():
    assert tolerances(0.0, error=PlanarArmError, pair=False, zero=True) == (0.0, 0.0)
    with pytest.raises(PlanarArmError, match="tol = -1 must be a number >= 0"):
        tolerances(-1, error=PlanarArmError, pair=False, zero=True)
    with pytest.raises(PlanarArmError, match="must be a number >= 0"):
        tolerances((1e-9, 1e-9), error=PlanarArmError, pair=False, zero=True)
    for solve in (lambda: ik(manipkit.load("planar_2r"), np.eye(4), tol=0.0),
                  lambda: analytic_ik(manipkit.load("planar_2r"), np.eye(4), tol=0.0),
                  lambda: decoupled.ik_stanford(np.eye(4), tol=0.0)):
        with pytest.raises((IKOptionError, ClosedFormIKError), match="tol must be a positive number"):
            solve()


# --------------------------------------------------------------------------
# the fast constructors of the compiled single calls


def checked_rows_result():
    """A result of IKResult.of_checked_rows (3 rows of 3 joints), as a compiled single call makes it."""
    block = np.arange(24, dtype=float).reshape(3, 8)
    block.setflags(write=False)
    within = block[:, 3] > 10.0
    within.setflags(write=False)
    refined = np.zeros(3)
    refined.setflags(write=False)
    return IKResult.of_checked_rows(block[:, :3], ("a", "b", "c"), "note", block[:, 4], block[:, 5], within, refined,
                                    mode=MODES[3], solver="s", joint_names=("j1", "j2", "j3"))


def test_a_result_of_checked_rows_has_every_other_field_at_its_default_through_copies_and_pickles():
    """of_checked_rows writes only the fields it is given; the others read as the dataclass's defaults, also after
    dataclasses.replace, copy.copy and a pickle round trip."""
    import copy
    import dataclasses
    import pickle

    fast = checked_rows_result()
    given = {"solutions", "labels", "count", "note", "residual_position", "residual_rotation", "mode", "solver",
             "joint_names", "within_limits", "refined"}
    for answer in (fast, dataclasses.replace(fast), copy.copy(fast), pickle.loads(pickle.dumps(fast))):
        for f in dataclasses.fields(IKResult):
            value = getattr(answer, f.name)
            if f.name in given:
                expected = getattr(fast, f.name)
                assert (np.array_equal(value, expected) if isinstance(value, np.ndarray) else value == expected), f.name
            else:
                assert value == f.default or (value is None and f.default is None), f.name
        assert answer.count == 3 and answer.free_joints == () and answer.unmet == () and answer.family_function is None
    moved = dataclasses.replace(fast, note="other")
    assert moved.note == "other" and fast.note == "note" and moved.labels == fast.labels


def test_with_rows_changes_the_rows_names_and_free_joints_only():
    fast = checked_rows_result()
    rows = np.hstack([np.full((3, 1), 0.5), fast.solutions])  # a whole-robot joint before the chain's
    rows.setflags(write=False)
    whole = fast.with_rows(rows, ("j0", "j1", "j2", "j3"), (2,))
    assert whole.solutions is rows and whole.joint_names == ("j0", "j1", "j2", "j3") and whole.free_joints == (2,)
    assert whole.labels == fast.labels and whole.note == fast.note and whole.count == fast.count
    for name in ("residual_position", "residual_rotation", "within_limits", "refined"):
        assert np.array_equal(getattr(whole, name), getattr(fast, name)) and not getattr(whole, name).flags.writeable
    assert fast.solutions.shape == (3, 3) and fast.joint_names == ("j1", "j2", "j3") and fast.free_joints == ()
    assert whole.q.tolist() == [0.5, 0.0, 1.0, 2.0] and whole.q_residuals.tolist() == [4.0, 5.0]


@pytest.mark.parametrize("rows", [np.zeros((3, 4)), np.zeros((2, 4)), np.zeros(4), [[0.0] * 4] * 3,
                                  np.zeros((3, 4), dtype=np.float32)])
def test_with_rows_refuses_writable_other_counts_or_shapes(rows):
    if isinstance(rows, np.ndarray) and rows.shape != (3, 4):
        rows.setflags(write=False)
    elif isinstance(rows, np.ndarray) and rows.dtype == np.float32:
        rows.setflags(write=False)
    with pytest.raises(ValueError, match="read-only float array of 3 rows"):
        checked_rows_result().with_rows(rows, ("j0", "j1", "j2", "j3"), ())


@pytest.mark.parametrize("writable", range(5))
def test_of_checked_rows_refuses_each_writable_array(writable):
    """Each of the five arrays is checked: any one of them writable (or not an ndarray) is refused."""
    arrays = [np.zeros((2, 3)), np.zeros(2), np.zeros(2), np.ones(2, dtype=bool), np.zeros(2)]
    for k, array in enumerate(arrays):
        array.setflags(write=k == writable)
    solutions, position, rotation, within, refined = arrays
    with pytest.raises(ValueError, match="read-only"):
        IKResult.of_checked_rows(solutions, ("a", "b"), "", position, rotation, within, refined, mode=MODES[3],
                                 solver="s", joint_names=())
    arrays[writable] = arrays[writable].tolist()  # not an ndarray
    with pytest.raises(ValueError, match="read-only"):
        IKResult.of_checked_rows(arrays[0], ("a", "b"), "", *arrays[1:], mode=MODES[3], solver="s", joint_names=())
