"""``manipkit torques`` and ``manipkit payload`` as a user runs them: the entry point called in process."""

import json

import numpy as np
import pinocchio as pin
import pytest
from cli_helper import run_cli

from manipkit.statics.torques import Payload, static_torques


def run(*args, status=0):
    result = run_cli("manipkit", *args, status=status)
    assert "Traceback" not in result.stdout + result.stderr
    return result


def test_torques_json_has_the_contract_keys_and_pinocchios_numbers(iiwa14):
    q = iiwa14.sample_q(1, seed=4)[0]
    report = json.loads(run("torques", "--robot", "iiwa14", "--q", *(repr(float(v)) for v in q), "--wrench", "1,-2,-5,0.1,0,0.3",
                            "--format", "json").stdout)
    assert {"joint_names", "tau", "gravity", "payload", "wrench", "effort_limit", "margin", "saturating"} <= set(report)
    assert report["joint_names"] == list(iiwa14.joint_names)
    # Pinocchio directly: the wrench at ee_link's origin (base axes = world axes here) as a force on joint 7's body
    model, data = iiwa14.model, iiwa14.model.createData()
    config = iiwa14.pinocchio_configuration(q)
    pin.framesForwardKinematics(model, data, config)
    frame = model.frames[iiwa14.frame_id("ee_link")]
    fext = pin.StdVec_Force()
    for _ in range(model.njoints):
        fext.append(pin.Force.Zero())
    at_tip = pin.SE3(np.eye(3), data.oMf[iiwa14.frame_id("ee_link")].translation)
    fext[frame.parentJoint] = data.oMi[frame.parentJoint].actInv(at_tip.act(pin.Force(np.array([1, -2, -5.0]),
                                                                                      np.array([0.1, 0, 0.3]))))
    np.testing.assert_allclose(report["tau"], pin.computeStaticTorque(model, data, config, fext), rtol=0, atol=1e-10)
    np.testing.assert_allclose(report["gravity"], pin.computeGeneralizedGravity(model, data, config), rtol=0,
                               atol=1e-10)
    assert report["payload"] == [0.0] * 7
    limits = np.array(report["effort_limit"])
    np.testing.assert_allclose(report["margin"], 100 * (1 - np.abs(report["tau"]) / limits), rtol=0, atol=1e-10)
    assert report["saturating"] == report["joint_names"][int(np.argmin(report["margin"]))]


def test_torques_payload_and_frame_axes_match_the_library(panda):
    chain = panda.chain("base_link", "ee_link")
    q = chain.sample(1, seed=1)[0]
    words = [f"{name}={float(value)!r}" for name, value in zip(chain.joint_names, q)]
    report = json.loads(run("torques", "--robot", "panda", "--q", *words, "--payload", "1.5@0,0.02,0.1",
                            "--wrench", "0,0,-5,0,0,0@panda_link7", "--wrench-axes", "frame",
                            "--format", "json").stdout)
    from manipkit.statics.torques import Wrench

    expected = static_torques(chain, q, payload=Payload(1.5, (0, 0.02, 0.1)),
                              wrench=Wrench((0, 0, -5, 0, 0, 0), "panda_link7", "frame"))
    assert report["joint_names"] == list(chain.joint_names)  # the chain's joints, not the finger
    np.testing.assert_allclose(report["tau"], expected.tau, rtol=0, atol=1e-12)
    np.testing.assert_allclose(report["payload"], expected.payload, rtol=0, atol=1e-12)


def test_torques_text_names_the_convention_and_the_least_margin():
    out = run("torques", "--robot", "iiwa14", "--q", "iiwa_joint_2=0.6", "--payload", "3").stdout
    assert "tau = g(q) - sum J^T w" in out and "least margin: iiwa_joint_" in out
    assert "margin %" in out


def test_payload_json_round_trips_through_torques(iiwa14):
    report = json.loads(run("payload", "--robot", "iiwa14", "--q", "iiwa_joint_2=0.6", "iiwa_joint_4=-1.2",
                            "--cog", "0,0,0.1", "--format", "json").stdout)
    assert report["saturating"] in iiwa14.joint_names and report["max_mass"] > 0
    q = iiwa14.q(iiwa_joint_2=0.6, iiwa_joint_4=-1.2)
    at = static_torques(iiwa14, q, payload=Payload(report["max_mass"], (0, 0, 0.1)))
    k = list(at.joint_names).index(report["saturating"])
    assert abs(abs(at.tau[k]) - at.effort_limit[k]) < 1e-9
    text = run("payload", "--robot", "iiwa14", "--q", "iiwa_joint_2=0.6", "iiwa_joint_4=-1.2", "--cog",
               "0,0,0.1").stdout
    assert f"({report['saturating']} reaches its effort limit)" in text


@pytest.mark.parametrize("args, fragment", [
    (["torques", "--payload", "1@0,0"], "--payload 1@0,0: give the centre of gravity after @ as 3 finite numbers"),
    (["torques", "--payload", "heavy"], "give MASS[@X,Y,Z]"),
    (["torques", "--wrench", "1,2,3@ee_link"], "--wrench 1,2,3: give 6 finite numbers"),
    (["torques", "--wrench", "1,2,3,4,5,6@"], "name the frame after @"),
    (["torques", "--gravity", "0,0"], "--gravity 0,0: give 3 finite numbers"),
    (["payload", "--cog", "0,inf,0"], "--cog 0,inf,0: give 3 finite numbers"),
])
def test_malformed_values_get_one_line_and_exit_2(args, fragment):
    result = run(*args, "--robot", "iiwa14", status=2)
    assert result.stderr.count("\n") == 1 and fragment in result.stderr, result.stderr


def test_payload_diagram_writes_a_png_and_prints_its_data(tmp_path, iiwa14):
    from manipkit.statics.diagram import payload_diagram

    png = tmp_path / "diagram.png"
    report = json.loads(run("payload", "--robot", "iiwa14", "--diagram", str(png), "--samples", "40", "--steps", "3",
                            "--max-offset", "0.2", "--format", "json").stdout)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert report["offsets"] == [0.0, 0.1, 0.2] and report["configurations"] == 40
    expected = payload_diagram(iiwa14, [0.0, 0.1, 0.2], samples=40, seed=0)
    np.testing.assert_allclose(report["worst_mass"], expected.worst, rtol=0, atol=1e-12)
    assert report["worst_joint"] == list(expected.worst_joint)


def test_torques_band_and_explain_match_the_library(panda):
    from manipkit.statics.sensitivity import gravity_contributions, torque_band
    from manipkit.statics.torques import Wrench

    q = panda.q(panda_joint2=0.5, panda_joint4=-1.5)
    report = json.loads(run("torques", "--robot", "panda", "--q", "panda_joint2=0.5", "panda_joint4=-1.5",
                            "--wrench", "0,0,-5,0,0,0", "--band", "10", "--explain", "--format", "json").stdout)
    band = torque_band(panda, q, percent=10)
    wrench = static_torques(panda, q, wrench=Wrench((0, 0, -5, 0, 0, 0))).wrench
    np.testing.assert_allclose(report["band"]["tau_low"], band.low + wrench, rtol=0, atol=1e-12)
    np.testing.assert_allclose(report["band"]["tau_high"], band.high + wrench, rtol=0, atol=1e-12)
    parts = gravity_contributions(panda, q)
    assert [p["link"] for p in report["explain"]["gravity_by_body"]] == [link for link, _, _ in parts]
    np.testing.assert_allclose(report["explain"]["total_gravity"], report["gravity"], rtol=0, atol=1e-10)
    item = report["explain"]["wrenches"][0]
    np.testing.assert_allclose(np.add(item["force_part"], item["moment_part"]), report["wrench"], rtol=0, atol=1e-12)
    text = run("torques", "--robot", "panda", "--q", "panda_joint2=0.5", "--explain").stdout
    assert "gravity torque by body (N m;" in text and "panda_leftfinger" in text


def test_payload_band_brackets_the_capacity():
    report = json.loads(run("payload", "--robot", "iiwa14", "--q", "iiwa_joint_2=0.5", "--cog", "0,0,0.1",
                            "--band", "10", "--format", "json").stdout)
    assert report["band"]["max_mass_low"] <= report["max_mass"] <= report["band"]["max_mass_high"]


def test_payload_band_of_an_unbounded_capacity_is_said_true_and_valid_json():
    # planar_2r's joints turn about z, the default gravity's line: a payload loads no joint (checked independently
    # below by the static torques of a 10 kg payload), so neither end of the band is a number of kg
    import manipkit

    robot = manipkit.load("planar_2r")
    assert np.abs(static_torques(robot, robot.q(), payload=Payload(10.0, (0.0, 0.0, 0.0))).payload).max() < 1e-12
    text = run("payload", "--robot", "planar_2r", "--band", "10").stdout
    assert "inf" not in text and "off by up to 10.000 %: unbounded as well" in text, text
    report = json.loads(run("payload", "--robot", "planar_2r", "--band", "10", "--format", "json").stdout)
    assert report["unbounded"] and report["band"]["max_mass_low"] is None and report["band"]["unbounded_high"]


def test_force_capacity_json_round_trips(iiwa14):
    from manipkit.statics.torques import Wrench

    report = json.loads(run("force-capacity", "--robot", "iiwa14", "--q", "iiwa_joint_2=0.5", "iiwa_joint_4=-1",
                            "--direction", "0,0,-1", "--direction", "1,1,0", "--format", "json").stdout)
    assert report["kind"] == "force" and report["unit"] == "N" and len(report["max_along"]) == 2
    q = iiwa14.q(iiwa_joint_2=0.5, iiwa_joint_4=-1)
    for d, t, joint in zip(report["directions"], report["max_along"], report["saturating"]):
        at = static_torques(iiwa14, q, wrench=Wrench(np.concatenate([-t * np.array(d), np.zeros(3)])))
        k = at.joint_names.index(joint)
        assert abs(abs(at.tau[k]) - at.effort_limit[k]) < 1e-9
    result = run("force-capacity", "--robot", "iiwa14", "--direction", "0,0,0", status=2)
    assert "give a direction that is not zero" in result.stderr
