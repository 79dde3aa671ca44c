"""The peers manipkit is compared with, each loaded from the same URDF text as manipkit.

Every peer gets the robot's own URDF (``robot.urdf``, the expanded text
manipkit loads) written to a temporary file, with ``<visual>`` and
``<collision>`` elements removed (meshes are not kinematics, and some
loaders try to open them). Each adapter answers for the chain from the
robot's root link to its ``ee_link`` frame, taking the chain's joint values
in chain order (base first); :func:`chain_columns` maps manipkit's joint
vectors to that order.

A peer that is not installed is reported as missing (with the reason), never
as slow or wrong: `make bench` installs them with ``pip install -e '.[bench]'``.
"""

from __future__ import annotations

import contextlib
import io
import re
import warnings
import xml.etree.ElementTree as ET
from importlib import metadata
from pathlib import Path

import numpy as np

PEER_PACKAGES = {"rtb": "roboticstoolbox-python", "ikpy": "ikpy", "kinpy": "kinpy"}


def version(distribution: str) -> str | None:
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return None


def missing_reason(peer: str) -> str | None:
    """None when the peer's package is installed, else a one-line reason."""
    dist = PEER_PACKAGES[peer]
    return None if version(dist) else f"{dist} is not installed (`make bench` installs the bench extra)"


@contextlib.contextmanager
def _quiet():
    """Silence a peer's loader chatter (kinpy's urdf parser prints every unknown attribute)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            yield


def kinematic_urdf(robot) -> str:
    """``robot.urdf`` without visual and collision elements (kinematics unchanged)."""
    return re.sub(r"<(visual|collision)\b.*?</\1>", "", robot.urdf, flags=re.S)


def write_urdf(robot, folder: Path) -> Path:
    path = Path(folder) / f"{robot.source.name}.urdf"
    path.write_text(kinematic_urdf(robot), encoding="utf-8")
    return path


def chain_elements(robot, tip: str) -> list[str]:
    """Link and joint names from the root link to ``tip``, alternating: [root, joint, link, ..., tip]."""
    root = ET.fromstring(robot.urdf)
    parent_joint = {j.find("child").get("link"): j for j in root.findall("joint")}
    names, link = [], robot.frame(tip)
    while link in parent_joint:
        joint = parent_joint[link]
        names[:0] = [joint.get("name"), link]
        link = joint.find("parent").get("link")
    return [link, *names]


def chain_columns(robot, tip: str = "ee_link") -> np.ndarray:
    """Columns of manipkit's joint vector that are the chain's joints, base first."""
    index = {name: i for i, name in enumerate(robot.joint_names)}
    return np.array([index[name] for name in robot.chain_joints(robot.root_link, tip)], dtype=np.intp)


# --------------------------------------------------------------------------


class RoboticsToolbox:
    """Peter Corke's Robotics Toolbox for Python: ``Robot.URDF``, ``fkine``, ``ik_LM`` (C++), ``ikine_LM``."""

    name = "Robotics Toolbox"

    def __init__(self, robot, urdf_path: Path):
        with _quiet():
            import roboticstoolbox as rtb

            self.robot = rtb.Robot.URDF(str(urdf_path))
        self.end = robot.frame("ee_link")
        self.ets = self.robot.ets(end=self.end)  # prepared once for the IK solvers, as its docs advise
        self.version = version("roboticstoolbox-python")

    def fk(self, q: np.ndarray) -> np.ndarray:
        return self.robot.fkine(q, end=self.end).A

    def fk_batch_call(self, Q: np.ndarray):
        """The batched call as a user makes it: an SE3 holding N poses."""
        return self.robot.fkine(Q, end=self.end)

    def fk_batch(self, Q: np.ndarray) -> np.ndarray:
        return np.array(self.fk_batch_call(Q).A)

    def jacobian_manipulability(self, q: np.ndarray) -> tuple[np.ndarray, float]:
        """``jacob0`` on the prepared ETS (C++) and ``manipulability(J=J)`` (Yoshikawa, all rows), as a user calls them."""
        J = self.ets.jacob0(q)
        return J, float(self.robot.manipulability(J=J, end=self.end, method="yoshikawa", axes="all"))

    def ik_LM(self, T: np.ndarray, q0: np.ndarray, *, tol: float) -> np.ndarray:
        return self.ets.ik_LM(T, q0=q0, tol=tol).q

    def ikine_LM(self, T: np.ndarray, q0: np.ndarray, *, tol: float, seed: int) -> np.ndarray:
        return self.ets.ikine_LM(T, q0=q0, tol=tol, seed=seed).q


class Ikpy:
    """ikpy: ``Chain.from_urdf_file`` along the root -> ee_link elements; ``forward_kinematics``, IK."""

    name = "ikpy"

    def __init__(self, robot, urdf_path: Path):
        with _quiet():
            from ikpy.chain import Chain

            elements = chain_elements(robot, "ee_link")
            chain = Chain.from_urdf_file(str(urdf_path), base_elements=elements)
            active = [link.joint_type != "fixed" for link in chain.links]
            self.chain = Chain.from_urdf_file(str(urdf_path), base_elements=elements, active_links_mask=active)
        self.active = np.array(active, dtype=bool)
        self.version = version("ikpy")

    def _full(self, q: np.ndarray) -> np.ndarray:
        full = np.zeros(self.active.size)
        full[self.active] = q
        return full

    def fk(self, q: np.ndarray) -> np.ndarray:
        return self.chain.forward_kinematics(self._full(q))

    def ik(self, T: np.ndarray, q0: np.ndarray) -> np.ndarray:
        with _quiet():
            full = self.chain.inverse_kinematics_frame(T, initial_position=self._full(q0), orientation_mode="all")
        return np.asarray(full)[self.active]


class Kinpy:
    """kinpy: ``build_serial_chain_from_urdf(text, ee, root)``, ``forward_kinematics``."""

    name = "kinpy"

    def __init__(self, robot, urdf_path: Path):
        with _quiet():
            import kinpy

            self.chain = kinpy.build_serial_chain_from_urdf(
                Path(urdf_path).read_bytes(), robot.frame("ee_link"), robot.root_link
            )
        self.version = version("kinpy")

    def fk(self, q: np.ndarray) -> np.ndarray:
        return self.chain.forward_kinematics(q).matrix()


PEERS = {"rtb": RoboticsToolbox, "ikpy": Ikpy, "kinpy": Kinpy}


def load_peer(peer: str, robot, urdf_path: Path):
    """(adapter, None) or (None, reason): a missing package or a loader that fails is a reason, not a crash."""
    reason = missing_reason(peer)
    if reason:
        return None, reason
    try:
        return PEERS[peer](robot, urdf_path), None
    except Exception as exc:  # a peer's loader failing on this URDF is a finding to report
        return None, f"{PEER_PACKAGES[peer]} could not load {urdf_path.name}: {type(exc).__name__}: {exc}"
