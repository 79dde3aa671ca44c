"""Tesseract's Descartes planner on the paths in a file, run in Tesseract's own venv (not manipkit's).

    PEER_PYTHON benchmarks/peer_tesseract.py IN.npz OUT.npz

The same files as ``peer_roboplan.py``. The robot is the URDF without its ``<visual>``/``<collision>`` elements
(Tesseract resolves no ``package://`` meshes here), a group ``manipulator`` = ``base`` -> ``tip``, KDL for FK and
Tesseract's UR closed form (``URInvKin``, model UR5) for every IK branch. One ``MoveInstruction`` (LINEAR) per
pose, ``generateInterpolatedProgram`` with one step per segment (no extra poses), ``DescartesMotionPlannerD``
with the default plan profile (its edge cost: joint distance; no joint velocity limit). OUT's ``q_K`` holds the
state waypoints of the answer. Standard library, numpy and tesseract_robotics only.
"""

from __future__ import annotations

import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

__all__ = ["main"]

NAMESPACE = "DescartesMotionPlannerTask"
PLUGINS = """kinematic_plugins:
  search_libraries: [tesseract_kinematics_kdl_factories, tesseract_kinematics_ur_factory]
  fwd_kin_plugins:
    manipulator:
      default: KDLFwdKinChain
      plugins:
        KDLFwdKinChain: {{class: KDLFwdKinChainFactory, config: {{base_link: {base}, tip_link: {tip}}}}}
  inv_kin_plugins:
    manipulator:
      default: URInvKin
      plugins:
        URInvKin: {{class: URInvKinFactory, config: {{base_link: {base}, tip_link: {tip}, model: UR5}}}}
"""
CONTACTS = """contact_manager_plugins:
  search_libraries: [tesseract_collision_bullet_factories]
  discrete_plugins:
    default: BulletDiscreteBVHManager
    plugins:
      BulletDiscreteBVHManager: {class: BulletDiscreteBVHManagerFactory}
  continuous_plugins:
    default: BulletCastBVHManager
    plugins:
      BulletCastBVHManager: {class: BulletCastBVHManagerFactory}
"""
SRDF = """<?xml version="1.0"?>
<robot name="{name}">
  <group name="manipulator"><chain base_link="{base}" tip_link="{tip}"/></group>
  <kinematics_plugin_config filename="file://{plugins}"/>
  <contact_managers_plugin_config filename="file://{contacts}"/>
</robot>
"""


def main(argv=None) -> int:
    source, target = (argv or sys.argv[1:])[:2]
    from tesseract_robotics import tesseract_command_language as cl
    from tesseract_robotics.tesseract_common import GeneralResourceLocator, Isometry3d, ManipulatorInfo
    from tesseract_robotics.tesseract_environment import Environment
    from tesseract_robotics.tesseract_motion_planners import PlannerRequest
    from tesseract_robotics.tesseract_motion_planners_descartes import (
        DescartesDefaultPlanProfileD,
        DescartesMotionPlannerD,
        cast_DescartesPlanProfileD,
    )
    from tesseract_robotics.tesseract_motion_planners_simple import generateInterpolatedProgram

    data = np.load(source)
    base, tip = str(data["base"]), str(data["tip"])
    text = Path(str(data["urdf"])).read_text(encoding="utf-8")
    urdf = re.sub(r"<(visual|collision)\b.*?</\1>", "", text, flags=re.S)
    name = re.search(r'<robot[^>]*name="([^"]+)"', urdf).group(1)
    out = {}
    with tempfile.TemporaryDirectory() as folder:
        plugins = Path(folder, "plugins.yaml")
        plugins.write_text(PLUGINS.format(base=base, tip=tip), encoding="utf-8")
        contacts = Path(folder, "contacts.yaml")
        contacts.write_text(CONTACTS, encoding="utf-8")
        env = Environment()
        if not env.init(urdf, SRDF.format(name=name, base=base, tip=tip, plugins=plugins, contacts=contacts), GeneralResourceLocator()):
            raise SystemExit("tesseract: Environment.init failed")
    manip = ManipulatorInfo()
    manip.tcp_frame, manip.manipulator, manip.working_frame = tip, "manipulator", base
    manip.manipulator_ik_solver = "URInvKin"
    profile = DescartesDefaultPlanProfileD()
    profiles = cl.ProfileDictionary()
    profiles.addProfile(NAMESPACE, "PATH", cast_DescartesPlanProfileD(profile))
    planner = DescartesMotionPlannerD(NAMESPACE)
    for k in range(int(data["paths"])):
        start = time.perf_counter()
        try:
            program = cl.CompositeInstruction()
            program.setManipulatorInfo(manip)
            for T in data[f"poses_{k}"]:
                waypoint = cl.CartesianWaypointPoly_wrap_CartesianWaypoint(cl.CartesianWaypoint(Isometry3d(T)))
                move = cl.MoveInstruction(waypoint, cl.MoveInstructionType_LINEAR, "PATH", manip)
                program.appendMoveInstruction(cl.MoveInstructionPoly_wrap_MoveInstruction(move))
            request = PlannerRequest()
            request.instructions = generateInterpolatedProgram(program, env, 3.14, 1.0, 3.14, 1)
            request.env = env
            request.profiles = profiles
            response = planner.solve(request)
            if not response.successful:
                raise RuntimeError(f"Descartes: {response.message}")
            results = response.results  # kept alive: the flattened list points into it
            Q = []
            for instruction in results.flatten():
                move = cl.InstructionPoly_as_MoveInstructionPoly(instruction)
                waypoint = move.getWaypoint()
                if waypoint.isStateWaypoint():
                    Q.append(np.array(cl.WaypointPoly_as_StateWaypointPoly(waypoint).getPosition(), float))
            error = ""
        except Exception as exc:  # noqa: BLE001 - the peer's failure is the measured answer
            Q, error = [], f"{type(exc).__name__}: {exc}"
        out[f"seconds_{k}"] = time.perf_counter() - start
        out[f"error_{k}"] = error
        out[f"q_{k}"] = np.asarray(Q, float).reshape(-1, len(data["joint_names"]))
    np.savez(target, **out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
