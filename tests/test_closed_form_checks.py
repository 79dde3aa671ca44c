"""closed_form.checks.tolerance_pair: the one tolerance parser (ik_result.tolerances), remembered per value."""

import pytest

from manipkit.bounds import tolerances
from manipkit.closed_form.checks import tolerance_pair
from manipkit.errors import ClosedFormIKError, IKOptionError


@pytest.mark.parametrize("tol", [1e-9, 1, (1e-6, 1e-3), [1e-6, 1e-3], (2, 3.0), True])
def test_tolerance_pair_reads_as_tolerances_does_every_time(tol):
    assert tolerance_pair(tol) == tolerances(tol)
    assert tolerance_pair(tol) == tolerances(tol)  # the remembered answer is the same


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), (1e-6, 0.0), "x", (1e-6, float("inf"))])
def test_tolerance_pair_refuses_what_tolerances_refuses_with_the_error_asked(bad):
    for _ in range(2):  # never remembered
        with pytest.raises(ClosedFormIKError) as caught:
            tolerance_pair(bad, error=ClosedFormIKError, what="check_tol")
        with pytest.raises(ClosedFormIKError) as expected:
            tolerances(bad, error=ClosedFormIKError, what="check_tol")
        assert str(caught.value) == str(expected.value)
    with pytest.raises(IKOptionError):
        tolerance_pair(bad)



@pytest.mark.parametrize("tol", [5e-324, 1e-300, 1e-10, 1.7e308])
def test_one_positive_float_is_read_at_once_as_tolerances_reads_it(tol):
    assert tolerance_pair(tol) == tolerances(tol) == (tol, tol)
    assert tolerance_pair(tol, error=ClosedFormIKError, what="check_tol") == (tol, tol)


@pytest.mark.parametrize("bad", [float("inf"), -float("inf"), -5e-324, -0.0])
def test_floats_at_the_edges_are_refused_as_tolerances_refuses_them(bad):
    with pytest.raises(ClosedFormIKError) as caught:
        tolerance_pair(bad, error=ClosedFormIKError, what="check_tol")
    with pytest.raises(ClosedFormIKError) as expected:
        tolerances(bad, error=ClosedFormIKError, what="check_tol")
    assert str(caught.value) == str(expected.value)
