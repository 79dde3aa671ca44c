"""Manipulability indices and ellipsoids (analysis.manipulability) against hand derivations and numpy's SVD."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from manipkit.analysis.manipulability import (
    Ellipsoid,
    MixedUnitsWarning,
    condition_number,
    force_ellipsoid,
    manipulability,
    plot_ellipsoid,
    select_rows,
    singular_values,
    velocity_ellipsoid,
)
from manipkit.errors import ManipkitError
from manipkit.kinematics.jacobian import jacobian, jacobians, mass_matrix
from manipkit.spatial.rotations import matrix_from_rpy

# ---------------------------------------------------------------------------
# Hand values


@pytest.fixture(scope="module")
def arm_2r(load_robot):
    return load_robot("planar_2r", l1="0.7", l2="0.4")


def test_planar_2r_yoshikawa_is_l1_l2_sin_q2(arm_2r):
    # J_xy = [[-l1 s1 - l2 s12, -l2 s12], [l1 c1 + l2 c12, l2 c12]] (dp/dq of p = l1 e(q1) + l2 e(q1 + q2)), so
    # det J_xy = (-l1 s1 - l2 s12) l2 c12 + l2 s12 (l1 c1 + l2 c12) = l1 l2 (s12 c1 - s1 c12) = l1 l2 sin q2.
    # "trans" adds the row vz = 0: J_t^T J_t = J_xy^T J_xy, so the two singular values and their product
    # are those of J_xy: w = l1 l2 |sin q2|.
    Q = np.column_stack([np.linspace(-3, 3, 13), np.linspace(-3.1, 3.1, 13)])
    expected = 0.7 * 0.4 * np.abs(np.sin(Q[:, 1]))
    J = jacobians(arm_2r, Q)
    np.testing.assert_allclose(manipulability(J, axes="trans"), expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(manipulability(J, axes=[0, 1]), expected, rtol=1e-12, atol=1e-15)
    assert manipulability(jacobian(arm_2r, [0.3, 0.0]), axes="trans") < 1e-16  # straight arm: singular


def test_planar_3r_hand_values(load_robot):
    robot = load_robot("planar_3r")  # l1, l2, l3 = 4, 2, 1
    l1, l2, l3 = 4.0, 2.0, 1.0
    for q1, q2, q3 in [(0.3, 0.9, -1.2), (-2.0, 2.5, 0.4), (1.0, 0.0, 0.0)]:
        J = jacobian(robot, [q1, q2, q3])
        # Rows vx, vy, wz: subtracting column 3 from columns 1 and 2 leaves [[J_2R, *], [0, 0, 1]] with J_2R the 2R
        # Jacobian of links l1, l2, so det = l1 l2 sin q2; the angular row times L multiplies it by L.
        np.testing.assert_allclose(manipulability(J, axes=[0, 1, 5], length=1.0), l1 * l2 * abs(np.sin(q2)),
                                   rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(manipulability(J, axes=[0, 1, 5], length=0.5), 0.5 * l1 * l2 * abs(np.sin(q2)),
                                   rtol=1e-12, atol=1e-14)
        # Rows vx, vy (2 x 3): det(J J^T) is the sum of the squared 2x2 minors (Cauchy-Binet). Columns are
        # z x (p - o_j), so the minor of columns i, j is (o_j - o_i) x (p - o_j) (2D cross product):
        # m12 = l1 l2 sin q2 + l1 l3 sin(q2 + q3), m13 = l1 l3 sin(q2 + q3) + l2 l3 sin q3, m23 = l2 l3 sin q3.
        m12 = l1 * l2 * np.sin(q2) + l1 * l3 * np.sin(q2 + q3)
        m13 = l1 * l3 * np.sin(q2 + q3) + l2 * l3 * np.sin(q3)
        m23 = l2 * l3 * np.sin(q3)
        np.testing.assert_allclose(manipulability(J, axes=[0, 1]), np.sqrt(m12**2 + m13**2 + m23**2),
                                   rtol=1e-12, atol=1e-14)
        # "trans" of a planar 3R: 3 x 3 with the zero row vz, so the product of its three singular values is 0.
        assert manipulability(J, axes="trans") < 1e-14


def test_scara_yoshikawa_is_a1_a2_sin_q2(load_robot):
    robot = load_robot("scara")  # a1 = 0.35, a2 = 0.25
    for q in robot.sample_q(8, seed=2):
        J = jacobian(robot, q)
        # Rows vx vy vz wz: joints 1 and 2 turn about +z, the quill slides along -z, the tool rolls about -z through
        # the tip, so J = [[-y, -a2 s12, 0, 0], [x, a2 c12, 0, 0], [0, 0, -1, 0], [1, 1, 0, -1]]: block lower
        # triangular, det = (-y a2 c12 + x a2 s12) (-1)(-1) = a2 (x s12 - y c12) = a1 a2 sin q2
        # (x = a1 c1 + a2 c12, y = a1 s1 + a2 s12). "trans" (3 x 4) has J_t J_t^T block diagonal with the same det.
        expected = 0.35 * 0.25 * abs(np.sin(q[1]))
        np.testing.assert_allclose(manipulability(J, axes=[0, 1, 2, 5], length=1.0), expected, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(manipulability(J, axes="trans"), expected, rtol=1e-12, atol=1e-15)


def test_2r_ellipse_by_hand(arm_2r):
    # At q = (0, 90 deg): J_xy = [[-l2, -l2], [l1, 0]] with l1 = 0.7, l2 = 0.4; J J^T = [[2 l2^2, -l1 l2], [-l1 l2, l1^2]]
    # whose eigenvalues are the squared radii: (tr +- sqrt(tr^2 - 4 det)) / 2 with tr = 2 l2^2 + l1^2, det = (l1 l2)^2.
    l1, l2 = 0.7, 0.4
    tr, det = 2 * l2**2 + l1**2, (l1 * l2) ** 2
    radii = np.sqrt([(tr + np.sqrt(tr**2 - 4 * det)) / 2, (tr - np.sqrt(tr**2 - 4 * det)) / 2])
    J = jacobian(arm_2r, [0.0, np.pi / 2])
    ellipse = velocity_ellipsoid(J, axes=[0, 1])
    np.testing.assert_allclose(ellipse.radii, radii, rtol=1e-12)
    np.testing.assert_allclose(force_ellipsoid(J, axes=[0, 1]).radii, 1 / radii, rtol=1e-12)
    np.testing.assert_allclose(velocity_ellipsoid(J).radii, [*radii, 0.0], rtol=1e-12, atol=1e-15)
    assert force_ellipsoid(J).radii[2] == np.inf


# ---------------------------------------------------------------------------
# Against numpy's SVD and by invariants

shapes = st.tuples(st.integers(1, 6), st.integers(1, 8))


@st.composite
def jacobian_matrices(draw):
    n = draw(st.integers(1, 8))
    # 0 or |entry| in [1e-6, 3]: entries near 1e-300 make 1 / sigma overflow, which says nothing about the code
    entries = st.one_of(st.just(0.0), st.floats(1e-6, 3.0), st.floats(-3.0, -1e-6))
    return draw(arrays(np.float64, (6, n), elements=entries))


row_sets = st.sampled_from(["all", "trans", "rot", [0, 1], [0, 1, 5], [2], [3, 4, 5, 0]])


@given(jacobian_matrices(), row_sets)
@settings(max_examples=200, deadline=None)  # the first call loads the compiled kernel
def test_yoshikawa_is_the_product_of_numpys_singular_values(J, axes):
    Js = select_rows(J, axes, 1.0)
    s = np.linalg.svd(Js, compute_uv=False)
    w = manipulability(J, axes=axes, length=1.0)
    assert w >= 0.0
    np.testing.assert_allclose(w, np.prod(s), rtol=1e-10, atol=1e-12 * max(1.0, s[0]) ** len(s))
    if Js.shape[0] <= Js.shape[1]:
        np.testing.assert_allclose(w**2, np.linalg.det(Js @ Js.T), rtol=1e-8, atol=1e-10 * max(1.0, s[0]) ** (2 * len(s)))


@given(jacobian_matrices(), row_sets, st.tuples(*[st.floats(-3, 3)] * 3))
@settings(max_examples=100, deadline=None)  # the first call loads the compiled kernel
def test_indices_do_not_depend_on_the_base_orientation(J, axes, rpy):
    # Turning the base turns v and w alike: J -> diag(R, R) J leaves every singular value unchanged.
    R = matrix_from_rpy(rpy)
    turned = np.vstack([R @ J[:3], R @ J[3:]])
    if isinstance(axes, str):  # a fixed subset of rows is not turned into itself
        for method in ("yoshikawa", "invcondition", "minsingular"):
            np.testing.assert_allclose(manipulability(turned, method, axes, length=0.7),
                                       manipulability(J, method, axes, length=0.7), rtol=1e-9, atol=1e-9)


@given(jacobian_matrices(), row_sets)
@settings(max_examples=100, deadline=None)  # the first call loads the compiled kernel
def test_condition_number_and_inverse_condition(J, axes):
    s = singular_values(J, axes, 2.0)
    assert np.all(np.diff(s) <= 0)
    inverse = manipulability(J, "invcondition", axes, 2.0)
    assert 0.0 <= inverse <= 1.0 + 1e-15
    kappa = condition_number(J, axes, 2.0)
    if s[-1] > 1e-12 * s[0]:
        np.testing.assert_allclose(inverse * kappa, 1.0, rtol=1e-12)
        np.testing.assert_allclose(manipulability(J, "minsingular", axes, 2.0), s[-1], rtol=1e-12)
    else:
        assert kappa > 1e11


@given(jacobian_matrices(), st.sampled_from(["trans", "rot"]))
@settings(max_examples=100, deadline=None)  # the first call loads the compiled kernel
def test_ellipsoid_axes_and_radii_rebuild_j_jt(J, axes):
    ellipsoid = velocity_ellipsoid(J, axes)
    U, r = ellipsoid
    np.testing.assert_allclose(U.T @ U, np.eye(3), atol=1e-12)
    Js = select_rows(J, axes)
    np.testing.assert_allclose((U * r**2) @ U.T, Js @ Js.T, atol=1e-10 * max(1.0, np.abs(J).max()) ** 2)
    force = force_ellipsoid(J, axes)
    np.testing.assert_array_equal(force.axes, U)
    np.testing.assert_allclose(force.radii * np.where(r > 0, r, np.inf), np.where(r > 0, 1.0, np.inf))


def test_batched_equals_one_at_a_time(iiwa14):
    J = jacobians(iiwa14, iiwa14.sample_q(30, seed=11).reshape(5, 6, 7))
    for method in ("yoshikawa", "invcondition", "minsingular"):
        batch = manipulability(J, method, "all", length=0.4)
        assert batch.shape == (5, 6)
        for index in np.ndindex(5, 6):
            np.testing.assert_allclose(batch[index], manipulability(J[index], method, "all", length=0.4), rtol=1e-13)
    ellipsoids = velocity_ellipsoid(J, "trans")
    assert ellipsoids.axes.shape == (5, 6, 3, 3) and ellipsoids.radii.shape == (5, 6, 3)


def test_asada_against_the_cartesian_inertia(iiwa14):
    for q in iiwa14.sample_q(4, seed=12):
        J, M = jacobian(iiwa14, q), mass_matrix(iiwa14, q)
        for axes in ("trans", "rot"):
            Js = select_rows(J, axes)
            Lambda = np.linalg.inv(Js @ np.linalg.inv(M) @ Js.T)  # the Cartesian inertia of the selected rows
            eigenvalues = np.sort(np.linalg.eigvals(Lambda).real)
            np.testing.assert_allclose(manipulability(J, "asada", axes, inertia=M), eigenvalues[0] / eigenvalues[-1],
                                       rtol=1e-9)
    J = jacobian(iiwa14, iiwa14.sample_q(1, seed=13)[0])
    # With M = I, J M^-1 J^T = J J^T: its eigenvalue ratio is the squared inverse condition number.
    np.testing.assert_allclose(manipulability(J, "asada", "trans", inertia=np.eye(7)),
                               manipulability(J, "invcondition", "trans") ** 2, rtol=1e-10)


def test_mass_matrix_equals_pinocchio_crba(iiwa14):
    import pinocchio as pin

    q = iiwa14.sample_q(1, seed=14)[0]
    data = iiwa14.model.createData()
    expected = pin.crba(iiwa14.model, data, iiwa14.pinocchio_configuration(q))
    M = mass_matrix(iiwa14, q)
    np.testing.assert_allclose(np.triu(M), np.triu(expected), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(M, M.T)


# ---------------------------------------------------------------------------
# Units


def test_mixed_rows_without_a_length_warn_with_the_fix():
    J = np.random.default_rng(0).normal(size=(6, 7))
    with pytest.warns(MixedUnitsWarning, match="pass length=L"):
        manipulability(J)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        manipulability(J, axes="trans")
        manipulability(J, axes="rot")
        manipulability(J, length=0.5)


def test_length_scales_the_angular_rows():
    J = np.random.default_rng(1).normal(size=(6, 7))
    scaled = J.copy()
    scaled[3:] *= 0.3
    np.testing.assert_allclose(manipulability(J, length=0.3), np.prod(np.linalg.svd(scaled, compute_uv=False)),
                               rtol=1e-12)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"method": "volume"}, "method='volume' is not one of"),
    ({"axes": "xyz"}, "axes='xyz'"),
    ({"axes": [0, 7]}, "row numbers 0-5"),
    ({"axes": [1, 1]}, "distinct"),
    ({"axes": "trans", "length": -1.0}, "length -1: give a length in metres from 1e-09"),
    ({"method": "asada", "axes": "trans"}, "needs the joint-space inertia"),
    ({"method": "asada", "axes": "trans", "inertia": np.eye(3)}, r"shape \(2, 2\)"),
])
def test_bad_options(kwargs, message):
    with pytest.raises(ManipkitError, match=message):
        manipulability(np.ones((6, 2)), **kwargs)


@pytest.mark.parametrize("J", [np.ones((3, 2)), np.ones(6), [[np.nan] * 2] * 6])
def test_bad_jacobians(J):
    with pytest.raises(ManipkitError, match="J must"):
        manipulability(J, axes="trans")


# ---------------------------------------------------------------------------
# Drawing


def test_plot_ellipse_2d_and_3d(arm_2r, iiwa14):
    from matplotlib.figure import Figure

    J = jacobian(arm_2r, [0.0, np.pi / 2])
    figure = Figure()
    ax = figure.add_subplot()
    # The 2-row ellipse and the shadow of the 3-row ellipsoid on x-y are the same ellipse.
    flat = plot_ellipsoid(ax, velocity_ellipsoid(J, [0, 1]), center=(1, 1, 0))
    shadow = plot_ellipsoid(ax, velocity_ellipsoid(J, "trans"), center=(1, 1, 0))
    l1, l2 = 0.7, 0.4
    tr, det = 2 * l2**2 + l1**2, (l1 * l2) ** 2
    major = 2 * np.sqrt((tr + np.sqrt(tr**2 - 4 * det)) / 2)
    for patch in (flat, shadow):
        assert patch.center == (1.0, 1.0)
        np.testing.assert_allclose(max(patch.width, patch.height), major, rtol=1e-12)
    np.testing.assert_allclose(np.cos(np.radians(flat.angle - shadow.angle)) ** 2, 1.0, atol=1e-12)
    ax3 = Figure().add_subplot(projection="3d")
    surface = plot_ellipsoid(ax3, velocity_ellipsoid(jacobian(iiwa14, iiwa14.sample_q(1, seed=1)[0])), scale=0.2)
    assert surface is not None
    with pytest.raises(ManipkitError, match="infinite radius"):
        plot_ellipsoid(ax, force_ellipsoid(J))
    with pytest.raises(ManipkitError, match="one ellipsoid"):
        plot_ellipsoid(ax, Ellipsoid(np.zeros((2, 3, 3)), np.ones((2, 3))))


def test_a_jacobian_without_columns_is_refused():
    # issue 26: manipulability of a (6, 0) array raised numpy's reshape ValueError
    with pytest.raises(ManipkitError, match=r"J has shape \(6, 0\): no columns"):
        manipulability(np.zeros((6, 0)), axes="trans")
