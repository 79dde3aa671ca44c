"""Static torques (manipkit.statics.torques) against a hand-derived planar 2R, energy and virtual work by central
differences, and Pinocchio's computeGeneralizedGravity / computeStaticTorque called directly."""

import numpy as np
import pinocchio as pin
import pytest

import manipkit
from manipkit.errors import ManipkitError, OptionError, UnknownFrameError
from manipkit.spatial.rotations import matrix_from_rpy
from manipkit.statics.torques import Payload, Wrench, static_torques

G = 9.81
L1, L2, R1, R2, M1, M2 = 0.7, 0.5, 0.3, 0.2, 2.0, 1.5


def point_mass_2r(effort=50.0) -> str:
    """A planar 2R about z, links along x: point masses M1 at R1 on link 1 and M2 at R2 on link 2 (zero inertia)."""
    def link(name, mass, x):
        return (f'<link name="{name}"><inertial><origin xyz="{x} 0 0"/><mass value="{mass}"/>'
                '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>')

    def joint(name, parent, child, x):
        return (f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="{x} 0 0"/><axis xyz="0 0 1"/>'
                f'<limit lower="-3.14" upper="3.14" effort="{effort}" velocity="1"/></joint>')

    return ('<robot name="point_2r"><link name="base_link"/>' + link("link1", M1, R1) + link("link2", M2, R2)
            + '<link name="ee_link"/>' + joint("joint1", "base_link", "link1", 0) + joint("joint2", "link1", "link2", L1)
            + f'<joint name="tool" type="fixed"><parent link="link2"/><child link="ee_link"/><origin xyz="{L2} 0 0"/>'
            '</joint></robot>')


@pytest.fixture(scope="module")
def point_2r(tmp_path_factory):
    path = tmp_path_factory.mktemp("statics") / "point_2r.urdf"
    path.write_text(point_mass_2r())
    return manipkit.load(str(path))


QS_2R = [(0.0, 0.0), (0.4, -1.1), (2.5, 0.9), (-1.3, 2.2)]


@pytest.mark.parametrize("q", QS_2R)
def test_planar_2r_point_masses_against_the_closed_form(point_2r, q):
    """Gravity along -y (in the plane): V = g [M1 R1 s1 + M2 (L1 s1 + R2 s12)] + mp g y_p, tau = dV/dq.

    g1 = g [(M1 R1 + M2 L1) c1 + M2 R2 c12], g2 = g M2 R2 c12. A payload mp with its CoG at (dx, dy) in the tool's
    axes sits at y_p = L1 s1 + (L2 + dx) s12 + dy c12: its part is mp g [L1 c1 + (L2 + dx) c12 - dy s12] on joint 1
    and mp g [(L2 + dx) c12 - dy s12] on joint 2. A force F = (fx, fy) on the tool at p = (L1 c1 + L2 c12,
    L1 s1 + L2 s12) needs -J^T F, J = [[-L1 s1 - L2 s12, -L2 s12], [L1 c1 + L2 c12, L2 c12]].
    """
    t1, t2 = q
    c1, s1, c12, s12 = np.cos(t1), np.sin(t1), np.cos(t1 + t2), np.sin(t1 + t2)
    mp, dx, dy = 1.2, 0.05, -0.08
    fx, fy = 3.0, -5.0
    gravity = [G * ((M1 * R1 + M2 * L1) * c1 + M2 * R2 * c12), G * M2 * R2 * c12]
    payload = [mp * G * (L1 * c1 + (L2 + dx) * c12 - dy * s12), mp * G * ((L2 + dx) * c12 - dy * s12)]
    J = np.array([[-L1 * s1 - L2 * s12, -L2 * s12], [L1 * c1 + L2 * c12, L2 * c12]])
    wrench = -J.T @ np.array([fx, fy])
    answer = static_torques(point_2r, q, payload=Payload(mp, (dx, dy, 0.0)), wrench=Wrench((fx, fy, 0, 0, 0, 0)),
                            gravity=(0.0, -G, 0.0))
    np.testing.assert_allclose(answer.gravity, gravity, rtol=0, atol=1e-10)
    np.testing.assert_allclose(answer.payload, payload, rtol=0, atol=1e-10)
    np.testing.assert_allclose(answer.wrench, wrench, rtol=0, atol=1e-10)
    np.testing.assert_allclose(answer.tau, np.add(gravity, payload) + wrench, rtol=0, atol=1e-10)
    np.testing.assert_allclose(answer.margin, 100 * (1 - np.abs(answer.tau) / 50.0), rtol=0, atol=1e-10)
    assert answer.saturating_joint == answer.joint_names[int(np.argmax(np.abs(answer.tau)))]


def test_gravity_perpendicular_to_the_plane_holds_nothing(point_2r):
    answer = static_torques(point_2r, (0.3, 0.4), payload=Payload(3.0, (0.1, 0.1, 0.1)))  # gravity along -z
    assert np.abs(answer.tau).max() < 1e-12


BUNDLED = ["planar_2r", "planar_3r", "course_arm", "scara", "stanford_arm", "elbow_arm", "iiwa14", "panda", "ur5"]


def potential_energy(robot, q_whole, gravity):
    """V = -M g . c(q): the total mass times its centre of gravity (Pinocchio's centerOfMass, from FK and masses)."""
    model = robot.model
    data = model.createData()
    c = pin.centerOfMass(model, data, robot.pinocchio_configuration(q_whole))
    return -data.mass[0] * float(np.dot(gravity, c))


@pytest.mark.parametrize("name", BUNDLED)
def test_gravity_is_the_gradient_of_the_potential_energy(load_robot, name):
    robot = load_robot(name)
    chain = robot.chain(robot.root_link, "ee_link")
    gravity = np.array([0.0, 0.0, -G])
    h = 1e-6
    for q in chain.sample(3, seed=5):
        answer = static_torques(chain, q, gravity=gravity)
        whole = chain.full(q)
        for k, column in enumerate(chain.columns):
            plus, minus = whole.copy(), whole.copy()
            plus[column] += h
            minus[column] -= h
            dV = (potential_energy(robot, plus, gravity) - potential_energy(robot, minus, gravity)) / (2 * h)
            assert abs(answer.gravity[k] - dV) < 1e-6, (name, chain.joint_names[k], answer.gravity[k], dV)


def skew_vee(W):
    return np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]]) / 2


@pytest.mark.parametrize("name, frame", [("iiwa14", "ee_link"), ("iiwa14", "iiwa_link_4"), ("panda", "panda_link5"),
                                         ("ur5", "ee_link"), ("stanford_arm", "ee_link")])
@pytest.mark.parametrize("axes", ["base", "frame"])
def test_wrench_part_is_the_virtual_work(load_robot, name, frame, axes):
    """The motors balance the wrench: tau_k dq_k = -(f . dp + n . dtheta), dp and dtheta by central differences of FK."""
    robot = load_robot(name)
    chain = robot.chain("base_link", "ee_link")
    w = np.array([3.0, -4.0, 5.0, 0.7, -0.2, 0.4])
    h = 1e-6
    for q in chain.sample(3, seed=9):
        whole = chain.full(q)
        answer = static_torques(chain, q, wrench=Wrench(w, frame, axes))
        R = robot.transform("base_link", frame, whole)[:3, :3]
        f, n = (w[:3], w[3:]) if axes == "base" else (R @ w[:3], R @ w[3:])
        for k, column in enumerate(chain.columns):
            plus, minus = whole.copy(), whole.copy()
            plus[column] += h
            minus[column] -= h
            T_plus, T_minus = robot.transform("base_link", frame, plus), robot.transform("base_link", frame, minus)
            dp = (T_plus[:3, 3] - T_minus[:3, 3]) / (2 * h)
            dtheta = skew_vee((T_plus[:3, :3] - T_minus[:3, :3]) / (2 * h) @ R.T)
            assert abs(answer.wrench[k] + f @ dp + n @ dtheta) < 1e-6


def pinocchio_static_torque(robot, chain, q, payload: Payload, frame: str, w_root):
    """Pinocchio called directly: the payload appended to the tip's joint body, the wrench (at ``frame``'s origin,
    components in the root's axes) as an external force in its joint's frame; computeStaticTorque, folded (S^T)."""
    model = robot.model.copy()
    tip = model.frames[robot.frame_id(chain.tip)]
    model.inertias[tip.parentJoint] = model.inertias[tip.parentJoint] + tip.placement.act(
        pin.Inertia(payload.mass, payload.cog, np.zeros((3, 3))))
    data = model.createData()
    config = robot.pinocchio_configuration(chain.full(q))
    pin.framesForwardKinematics(model, data, config)
    fext = pin.StdVec_Force()
    for _ in range(model.njoints):
        fext.append(pin.Force.Zero())
    target = model.frames[robot.frame_id(frame)]
    at_point = pin.Force(w_root[:3], w_root[3:])  # world-aligned axes at the frame's origin
    X = pin.SE3(np.eye(3), data.oMf[robot.frame_id(frame)].translation)
    fext[target.parentJoint] = data.oMi[target.parentJoint].actInv(X.act(at_point))
    tau = pin.computeStaticTorque(model, data, config, fext)
    g = pin.computeGeneralizedGravity(robot.model, robot.model.createData(), config)  # without the payload
    S = robot.velocity_map()
    return (S.T @ tau)[chain.columns], (S.T @ g)[chain.columns]


@pytest.mark.parametrize("name", ["iiwa14", "panda", "ur5"])
def test_equals_pinocchio_compute_static_torque(load_robot, name):
    robot = load_robot(name)
    chain = robot.chain("base_link", "ee_link")
    payload = Payload(2.3, (0.02, -0.03, 0.08))
    frame = chain.tip if name != "panda" else "panda_link6"
    w = np.array([2.0, -1.0, -5.0, 0.3, 0.1, -0.2])
    for q in chain.sample(10, seed=2):
        R_root_base = robot.transform(robot.root_link, "base_link", chain.full(q))[:3, :3]
        tau_pin, g_pin = pinocchio_static_torque(robot, chain, q, payload, frame,
                                                 np.concatenate([R_root_base @ w[:3], R_root_base @ w[3:]]))
        answer = static_torques(chain, q, payload=payload, wrench=Wrench(w, frame))
        np.testing.assert_allclose(answer.tau, tau_pin, rtol=0, atol=1e-10)
        plain = static_torques(chain, q)
        np.testing.assert_allclose(plain.tau, g_pin, rtol=0, atol=1e-10)
        np.testing.assert_allclose(plain.gravity, answer.gravity, rtol=0, atol=0)


@pytest.mark.parametrize("name", ["iiwa14", "panda", "ur5"])
def test_a_batch_across_lanes_equals_pinocchio_row_by_row(load_robot, name):
    # 601 rows: two full lanes of the kernel and a partial one (the lanes' count is not a divisor)
    from manipkit.statics.gravity_kernel import LANES

    robot = load_robot(name)
    chain = robot.chain("base_link", "ee_link")
    Q = chain.sample(601, seed=5)
    assert Q.shape[0] % LANES != 0
    payload = Payload(1.7, (0.01, 0.02, -0.05))
    batch = static_torques(chain, Q, payload=payload)
    for i in range(0, 601, 37):
        tau_pin, g_pin = pinocchio_static_torque(robot, chain, Q[i], payload, chain.tip, np.zeros(6))
        np.testing.assert_allclose(batch.tau[i], tau_pin, rtol=0, atol=1e-10)
        np.testing.assert_allclose(batch.gravity[i], g_pin, rtol=0, atol=1e-10)
    last = Q.shape[0] - 1
    tau_pin, _ = pinocchio_static_torque(robot, chain, Q[last], payload, chain.tip, np.zeros(6))
    np.testing.assert_allclose(batch.tau[last], tau_pin, rtol=0, atol=1e-10)


def test_batched_rows_equal_one_at_a_time(iiwa14):
    chain = iiwa14.chain("base_link", "ee_link")
    Q = chain.sample(40, seed=1)
    payload, wrench = Payload(1.5, (0, 0, 0.1)), Wrench((0, 0, -5, 0, 0, 0))
    batch = static_torques(chain, Q, payload=payload, wrench=wrench)
    assert batch.tau.shape == (40, 7) and batch.margin.shape == (40, 7) and batch.saturating.shape == (40,)
    for i in (0, 17, 39):
        one = static_torques(chain, Q[i], payload=payload, wrench=wrench)
        np.testing.assert_allclose(one.tau, batch.tau[i], rtol=0, atol=1e-12)
        assert one.saturating == batch.saturating[i]
    grid = static_torques(chain, Q.reshape(4, 10, 7))
    assert grid.tau.shape == (4, 10, 7)


def test_a_payload_of_mass_zero_changes_nothing(iiwa14):
    chain = iiwa14.chain("base_link", "ee_link")
    Q = chain.sample(20, seed=4)
    np.testing.assert_array_equal(static_torques(chain, Q, payload=Payload(0.0, (0.3, 0.2, 0.1))).tau,
                                  static_torques(chain, Q).tau)


def test_a_payload_adds_to_the_tip_link_instead_of_replacing_it(iiwa14):
    chain = iiwa14.chain("base_link", "ee_link")
    q = chain.sample(1, seed=6)[0]
    plain, loaded = static_torques(chain, q), static_torques(chain, q, payload=Payload(1.0))
    np.testing.assert_allclose(loaded.gravity, plain.gravity, rtol=0, atol=0)
    np.testing.assert_allclose(loaded.tau, plain.tau + loaded.payload, rtol=0, atol=1e-12)
    assert np.abs(loaded.payload).max() > 0.1


def test_rotating_the_base_and_gravity_together_changes_nothing(iiwa14):
    rpy = (0.3, -0.7, 1.1)
    mount = ('<link name="world"/><joint name="mount" type="fixed"><parent link="world"/><child link="base_link"/>'
             f'<origin xyz="0.4 -0.2 1.0" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/></joint>')
    text = iiwa14.urdf.replace("</robot>", mount + "</robot>")
    mounted = manipkit.Robot.from_urdf(text)
    assert mounted.root_link == "world"
    R = matrix_from_rpy(rpy)  # T_world_base: gravity g in the base's axes is R g in the world's
    g = np.array([0.0, 0.0, -G])
    Q = iiwa14.sample_q(15, seed=8)
    payload, wrench = Payload(2.0, (0.0, 0.05, 0.1)), Wrench((1, 2, -3, 0.1, 0, 0))
    plain = static_torques(iiwa14, Q, payload=payload, wrench=wrench, gravity=g)
    turned = static_torques(mounted, Q, payload=payload, wrench=wrench, gravity=R @ g)
    np.testing.assert_allclose(turned.tau, plain.tau, rtol=0, atol=1e-10)
    from_world = static_torques(mounted, Q, payload=payload, gravity=R @ g, base="world")
    np.testing.assert_allclose(from_world.gravity + from_world.payload, plain.gravity + plain.payload, rtol=0,
                               atol=1e-10)


def test_only_the_chain_joints_answer_and_fingers_weigh(panda):
    chain = panda.chain("base_link", "ee_link")
    answer = static_torques(chain, chain.sample(1, seed=0)[0])
    assert answer.joint_names == tuple(f"panda_joint{k}" for k in range(1, 8))
    assert answer.effort_limit.tolist() == [87.0] * 4 + [12.0] * 3


def test_missing_effort_limits_are_nan_and_name_no_saturating_joint(course_arm):
    answer = static_torques(course_arm, course_arm.q())
    assert np.isnan(answer.effort_limit).all() and np.isnan(answer.margin).all()
    assert answer.saturating_joint is None


@pytest.mark.parametrize("make, error", [
    (lambda: Payload(-1.0), "give a finite mass >= 0"),
    (lambda: Payload(float("nan")), "give a finite mass >= 0"),
    (lambda: Payload(1.0, (0.0, float("nan"), 0.0)), "every component must be a finite number"),
    (lambda: Payload(1.0, (0.0, 0.0)), "give 3 numbers"),
    (lambda: Payload(1.0, inertia=-np.eye(3)), "positive semidefinite"),
    (lambda: Wrench((1, 2, 3)), "give 6 numbers"),
    (lambda: Wrench((1, 2, 3, 4, 5, 6), axes="tool"), "is not one of"),
])
def test_bad_payloads_and_wrenches_say_what_is_wrong(make, error):
    with pytest.raises(OptionError, match=error):
        make()


def test_a_wrench_frame_that_does_not_exist_is_named(iiwa14):
    with pytest.raises(UnknownFrameError, match="no frame 'tool_tip'"):
        static_torques(iiwa14, iiwa14.q(), wrench=Wrench((0, 0, -5, 0, 0, 0), "tool_tip"))


def test_a_gravity_that_is_not_three_finite_numbers_is_refused(iiwa14):
    with pytest.raises(ManipkitError, match="gravity"):
        static_torques(iiwa14, iiwa14.q(), gravity=(0, 0, float("inf")))


def prismatic_mimic_arm() -> str:
    """Four joints, every kind the gravity pass meets: revolute, prismatic (a turned placement before it), a revolute
    mimic of the first (x -2 + 0.3: the leader's column gets the scaled sum), a prismatic mimic of the second, with
    CoGs off every axis."""
    def link(name, mass, xyz):
        return (f'<link name="{name}"><inertial><origin xyz="{xyz}"/><mass value="{mass}"/>'
                '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>')

    def joint(name, kind, parent, child, xyz, rpy, axis, extra=""):
        return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
                f'<limit lower="-2" upper="2" effort="80" velocity="1"/>{extra}</joint>')

    return ('<robot name="mixed"><link name="base_link"/>' + link("a", 2.0, "0.1 0.02 0.3")
            + link("b", 1.5, "0.05 -0.1 0.2") + link("c", 1.2, "0.2 0.1 -0.05") + link("d", 0.7, "-0.03 0.04 0.1")
            + '<link name="ee_link"/>'
            + joint("j1", "revolute", "base_link", "a", "0 0 0.3", "0 0 0", "0 0 1")
            + joint("j2", "prismatic", "a", "b", "0.2 0 0.4", "0.4 -0.3 0.2", "0.6 0 0.8")
            + joint("j3", "revolute", "b", "c", "0 0.3 0.1", "1.5707963 0 0", "0 1 0",
                    '<mimic joint="j1" multiplier="-2" offset="0.3"/>')
            + joint("j4", "prismatic", "c", "d", "0.25 0 0", "0 0.5 0", "1 0 0", '<mimic joint="j2" multiplier="0.5"/>')
            + '<joint name="tool" type="fixed"><parent link="d"/><child link="ee_link"/>'
            '<origin xyz="0.05 0.02 0.1" rpy="0.2 0.1 -0.4"/></joint></robot>')


def test_prismatic_and_mimic_steps_equal_pinocchio_across_lanes(tmp_path):
    # the lanes' recursion on every step kind: a prismatic step moves the first moment by M d z, a mimic step adds
    # its scaled torque to its leader's column; Pinocchio (mimic joints independent) folded by the velocity map
    from manipkit.statics.gravity_kernel import LANES
    from manipkit.statics.torques import margins

    path = tmp_path / "mixed.urdf"
    path.write_text(prismatic_mimic_arm())
    robot = manipkit.load(str(path))
    chain = robot.chain("base_link", "ee_link")
    assert chain.n == 2 and len(chain.steps) > chain.n
    Q = chain.sample(2 * LANES + 7, seed=11)
    payload = Payload(1.3, (0.02, -0.05, 0.07))
    batch = static_torques(chain, Q, payload=payload)
    for i in range(0, len(Q), 9):
        tau_pin, g_pin = pinocchio_static_torque(robot, chain, Q[i], payload, chain.tip, np.zeros(6))
        np.testing.assert_allclose(batch.tau[i], tau_pin, rtol=0, atol=1e-10)
        np.testing.assert_allclose(batch.gravity[i], g_pin, rtol=0, atol=1e-10)
    assert np.abs(batch.payload).max() > 0.1
    np.testing.assert_array_equal(batch.tau, batch.gravity + batch.payload)
    # the margins of the lanes are the rule of margins(), and the formula written here
    margin, saturating = margins(batch.tau, batch.effort_limit)
    np.testing.assert_array_equal(batch.margin, margin)
    np.testing.assert_array_equal(batch.saturating, saturating)
    np.testing.assert_array_equal(margin, 100.0 * (1.0 - np.abs(batch.tau) / 80.0))
    np.testing.assert_array_equal(saturating, np.argmin(margin, axis=1))
