"""A loaded robot: Pinocchio model, joints by name, transforms between frames.

Conventions (docs/architecture.md):

- Units are metres and radians.
- ``T_a_b`` is the pose of frame b expressed in frame a, a 4x4 homogeneous
  matrix; ``robot.transform("a", "b", q)`` returns it, as ``tf2_echo a b``
  prints it.
- A joint vector ``q`` has one value per independent degree of freedom, in
  the order of :attr:`Robot.joint_names`: an angle (rad) for revolute and
  continuous joints, a distance (m) for prismatic ones; mimic joints have
  none, floating and planar joints several (:mod:`manipkit.kinematics.joints`).
- Frames are links (and fixed-joint frames). Every robot also answers to
  ``base_link`` (:attr:`Robot.base_link`: the link of that name, else the
  root link) and ``ee_link`` (its end effector: a link of that name, the
  frame declared for it, or the tip of its longest chain).
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pinocchio as pin

from manipkit.description.access import ReadPolicy, allowed_folders
from manipkit.description.packages import PackageResolver, check_package_dirs
from manipkit.description.sources import RobotSource, resolve_robot
from manipkit.description.srdf import shipped_srdf
from manipkit.description.validate import cap_warnings, check_urdf, package_uri_warnings
from manipkit.description.xacro import describe, xacro_locator
from manipkit.errors import ChainError, DescriptionError, JointValueError, UnknownFrameError
from manipkit.kinematics.chain import (
    LIMIT_TOLERANCE,
    Chain,
    JointSpace,
    chain_columns,
    chain_steps,
    joint_array,
    limits_ok,
)
from manipkit.kinematics.joints import Joint, Mimic, build_model, joint_layout, root_link
from manipkit.kinematics.tool_frame import tool_frame_of
from manipkit.text import close_matches, quoted_name, repr_text, short_text

__all__ = ["BASE_ALIASES", "EE_ALIAS", "LIMIT_TOLERANCE", "MAX_DEGREES_OF_FREEDOM", "Joint", "Mimic", "Robot", "load"]

BASE_ALIASES = ("base_link", "world")
EE_ALIAS = "ee_link"
#: More movable joints than this are refused: Pinocchio's Data holds nv x nv x nv tensors
#: (about 0.6 GB at 200, 1.8 GB at 300, 64 GB at 1000); arms and humanoids have tens.
MAX_DEGREES_OF_FREEDOM = 200


def load(robot: str | os.PathLike | None = None, *, package_dirs: dict | None = None, allow_read=None,
         **xacro_args) -> Robot:
    """Load a robot by bundled name, example-robot-data name or path.

    Parameters
    ----------
    robot : str or path-like, optional
        ``course_arm`` (default), ``iiwa14``, ``panda``, ``ur5``,
        ``path/to/robot.urdf.xacro``, ... (see :func:`manipkit.description.sources.resolve_robot`).
    package_dirs : dict, optional
        Package name -> folder, for ``$(find PKG)`` and ``package://PKG``.
    allow_read : path-like or list of path-like, optional
        Folders the description may read besides its own folder tree and its packages
        (``--allow-read``; :mod:`manipkit.description.access`): xacro includes, YAML files, meshes.
    **xacro_args
        xacro arguments, e.g. ``load("planar_3r", l1=2)``.

    Raises
    ------
    ManipkitError
        A subclass naming the argument (wrong type, NUL byte, missing folder), or the description's problem.

    Examples
    --------
    >>> robot = load("course_arm")
    >>> robot.transform("base_link", "ee_link", robot.q()).shape
    (4, 4)
    """
    source = resolve_robot(robot)
    package_dirs = check_package_dirs(package_dirs, exist=False)  # a missing one the expansion uses: named there
    allowed = allowed_folders(allow_read)
    text, declared = describe(source, xacro_args, package_dirs, allow_read=allowed)
    check_package_dirs(package_dirs)
    used = {}
    if source.is_xacro:
        defaults = {k: v for k, v in declared.items() if v is not None}
        used = {**defaults, **{k: str(v) for k, v in xacro_args.items()}}
    return Robot.from_urdf(text, source=source, package_dirs=package_dirs, xacro_args=used, allow_read=allowed)


class Robot(JointSpace):
    """A robot model, immutable: the Pinocchio model, its joints and frames, and the chains between frames.

    Build it with :func:`load`. ``model`` is Pinocchio's; :attr:`data` is a
    Pinocchio workspace of the calling thread's own (each thread gets one), so
    two threads may call :meth:`transform`, :meth:`fk`, :meth:`jacobian` and
    IK on one robot at once. The rest of the API works with joint names, frame
    names and plain joint vectors (one value per movable joint, radians or
    metres). Assigning an attribute after construction raises ``AttributeError``.
    """

    def __init__(self, model: pin.Model, urdf: str, source: RobotSource, robot_xml, package_dirs=None, warnings=(),
                 *, xacro_args=None, mesh_warnings=(), allow_read=()):
        self.model = model
        if model.nv > MAX_DEGREES_OF_FREEDOM:  # checked before Pinocchio allocates its workspace
            raise DescriptionError(
                f"{source.path.name}: {model.nv} degrees of freedom; manipkit handles up to {MAX_DEGREES_OF_FREEDOM} "
                f"(Pinocchio's workspace grows with the cube of the count: about "
                f"{64 * model.nv ** 3 / 1e9:.2g} GB here)"
            )
        self._workspace = threading.local()  # one Pinocchio Data per thread (see data)
        try:
            self._workspace.data = model.createData()
        except MemoryError:
            raise DescriptionError(
                f"{source.path.name}: {model.nv} degrees of freedom: Pinocchio's workspace for this model does not "
                "fit in memory"
            ) from None
        self.urdf = urdf
        self.source = source
        self.name = robot_xml.get("name") or source.name
        self.package_dirs = dict(package_dirs or {})
        #: Folders the description may read besides its own tree and packages (``allow_read`` of :func:`load`).
        self.allow_read: tuple[Path, ...] = allowed_folders(allow_read)
        #: The xacro arguments the description was expanded with (declared defaults and the given ones).
        self.xacro_args: Mapping[str, str] = MappingProxyType(dict(xacro_args or {}))
        #: Problems found while loading that do not change the kinematics (a normalised axis, a joint
        #: that cannot move, an unresolved package:// mesh, ...), one line each; the CLI prints them
        #: as ``warning: ...`` on stderr.
        self.warnings: tuple[str, ...] = tuple(warnings)
        #: The subset of :attr:`warnings` about ``package://`` meshes that do not resolve (the viewer's
        #: one missing-mesh warning covers them).
        self.mesh_warnings: tuple[str, ...] = tuple(mesh_warnings)
        self._layout = joint_layout(model, robot_xml, source.path.name)
        self.joints: tuple[Joint, ...] = self._layout.joints
        self.joint_names = tuple(j.name for j in self.joints)
        #: URDF joints that follow another (``<mimic>``), by name: no entry of ``q``; their value is
        #: ``multiplier * q[leader] + offset`` (:class:`manipkit.kinematics.joints.Mimic`).
        self.mimic_joints: dict[str, Mimic] = self._layout.mimics
        self._joint_index = {j.name: i for i, j in enumerate(self.joints)}
        self._coordinates: dict[str, list[int]] = {}  # floating/planar joint name -> its entries of q
        for i, j in enumerate(self.joints):
            if j.coordinate is not None:
                self._coordinates.setdefault(j.joint, []).append(i)
        self.root_link = root_link(robot_xml)
        self.frame_names = tuple(
            f.name for f in model.frames if f.type == pin.FrameType.BODY and f.name != "universe"
        )
        self._frame_ids = {}
        for frame_id, frame in enumerate(model.frames):
            if frame.type == pin.FrameType.BODY:  # links only, first of a name wins
                self._frame_ids.setdefault(frame.name, frame_id)
        #: The link ``base_link`` means everywhere (CLI, :meth:`fk`'s default base, listings): the link
        #: named ``base_link`` if there is one, else the root link.
        self.base_link = "base_link" if "base_link" in self._frame_ids else self.root_link
        #: The SRDF the description ships (:func:`manipkit.description.srdf.shipped_srdf`), or None: its
        #: ``<disable_collisions>`` are the collision checks' default and its group tip ``ee_link``'s first choice.
        #: A robot loaded from MJCF has instead its file's contact rules (:func:`manipkit.description.mjcf.mjcf_rules`,
        #: ``kind`` ``"mjcf"``): MuJoCo's own allowed-collision source for it.
        if source.is_mjcf and source.path.is_file():
            from manipkit.description.mjcf import mjcf_rules  # here: MuJoCo's loader is only for MJCF files

            self.srdf, notes = mjcf_rules(source.path, self.name, allow_read=self.allow_read), ()
        else:
            self.srdf, notes = shipped_srdf(source.path, self.name, self.frame_names,
                                            PackageResolver(dict(self.package_dirs), near=source.path))
        #: Without :attr:`srdf`: why each SRDF for this robot's name was passed over (it names another link).
        self.srdf_notes: tuple[str, ...] = () if self.srdf is not None else notes
        self.ee_frame, self.ee_reason = tool_frame_of(model, self._frame_ids, source.ee_frame, source.name,
                                                      srdf=self.srdf)
        #: Joint limits (rad or m; infinite for a continuous joint), in :attr:`joint_names` order, read-only;
        #: the joint-space API (limits, clamp, sampling) is :class:`manipkit.kinematics.chain.JointSpace`'s.
        self.lower = np.array([j.lower for j in self.joints], dtype=float)
        self.upper = np.array([j.upper for j in self.joints], dtype=float)
        self.lower.setflags(write=False)
        self.upper.setflags(write=False)
        self._limits_ok = limits_ok(self.lower, self.upper)
        # Caches of derived, never-changing data (a race builds one twice, harmlessly):
        self._chain_objects: dict[tuple[str, str], Chain] = {}  # (base link, tip link) -> Chain
        self._frozen = True

    def __setattr__(self, name, value):
        if getattr(self, "_frozen", False):
            raise AttributeError(f"a Robot is immutable: cannot set '{name}' (load another robot instead)")
        object.__setattr__(self, name, value)

    def __getstate__(self) -> dict:
        """For pickling (Dask workers): the model and what was derived from it, without the caches and workspaces."""
        state = dict(self.__dict__)
        for name in ("_workspace", "_chain_objects"):
            state.pop(name)
        state["xacro_args"] = dict(self.xacro_args)
        return state

    def __setstate__(self, state: dict) -> None:
        state["xacro_args"] = MappingProxyType(state["xacro_args"])
        for name, value in state.items():
            object.__setattr__(self, name, value)
        for name in ("_chain_objects",):
            object.__setattr__(self, name, {})
        object.__setattr__(self, "_workspace", threading.local())

    @property
    def joint_layout(self):
        """How the joint vector maps onto Pinocchio's model (:class:`manipkit.kinematics.joints.JointLayout`)."""
        return self._layout

    @property
    def data(self) -> pin.Data:
        """A Pinocchio ``Data`` workspace for ``model``, the calling thread's own (made on the thread's first use)."""
        data = getattr(self._workspace, "data", None)
        if data is None:
            data = self._workspace.data = self.model.createData()
        return data

    @classmethod
    def from_urdf(cls, text: str, *, source: RobotSource | None = None, package_dirs=None, xacro_args=None,
                  allow_read=()) -> Robot:
        """Build a robot from URDF text, checked first by :func:`manipkit.description.validate.check_urdf`.

        Invalid descriptions raise :class:`DescriptionError` naming the file,
        line and element; problems that leave the kinematics right (a
        non-unit axis, normalised; a ``package://`` mesh that does not
        resolve) are collected in :attr:`warnings`.
        """
        if source is None:
            source = RobotSource("robot", Path("<string>"), "string")
        where = source.path.name
        locate = None
        if source.path.is_file() and source.is_xacro:
            locate = xacro_locator(source.path)
        elif source.path.is_file() and source.is_mjcf:
            from manipkit.description.mjcf import mjcf_locator  # here: MuJoCo's loader is only for MJCF files

            locate = mjcf_locator(source.path, allow_read=allow_read)
        checked = check_urdf(text, where, locate=locate)
        warnings = list(checked.warnings)
        near = source.path if source.path.is_file() else None
        resolver = PackageResolver({k: Path(v) for k, v in (package_dirs or {}).items()}, near=near)
        policy = ReadPolicy(near, resolver, allow_read) if near is not None else None
        mesh_warnings = package_uri_warnings(checked.robot, resolver, where, locate=locate, policy=policy)
        model, messages = build_model(checked.text)
        if model is None:
            reason = "; ".join(messages) or "no reason given"
            raise DescriptionError(f"{where}: Pinocchio cannot build a model: {reason}")
        warnings += mesh_warnings + cap_warnings([f"{where}: URDF parser: {m}" for m in messages], where)
        return cls(model, checked.text, source, checked.robot, package_dirs, warnings, xacro_args=xacro_args,
                   mesh_warnings=mesh_warnings, allow_read=allow_read)

    def __repr__(self) -> str:
        return (
            f"Robot({self.name!r}, {len(self.joints)} joints, base_link {self.base_link!r}, "
            f"ee_link {self.ee_frame!r}, from {self.source.path})"
        )

    def _repr_html_(self) -> str:
        """Jupyter: the robot's frames and a table of its joints (type, axis, limits; mimic joints after)."""
        from html import escape

        def limit(joint: Joint, value: float) -> str:
            if not math.isfinite(value):
                return "-"
            return f"{short_text(math.degrees(value))}&deg;" if joint.is_angular else f"{short_text(value)} m"

        rows = "".join(
            f"<tr><td>{escape(j.name)}</td><td>{escape(j.type)}</td><td>{' '.join(short_text(a) for a in j.axis)}</td>"
            f"<td>{escape(j.parent)} &rarr; {escape(j.child)}</td><td>{limit(j, j.lower)}</td><td>{limit(j, j.upper)}</td></tr>"
            for j in self.joints
        )
        rows += "".join(
            f"<tr><td>{escape(m.name)}</td><td>{escape(m.type)}</td><td colspan=\"4\">mimics {escape(m.leader)}: "
            f"{short_text(m.multiplier)} &times; {escape(m.leader)} + {short_text(m.offset)}</td></tr>"
            for m in self.mimic_joints.values()
        )
        return (
            f"<p><b>{escape(self.name)}</b> from <code>{escape(str(self.source.path))}</code>: "
            f"{len(self.joints)} joints, {len(self.frame_names)} frames; base_link = <code>{escape(self.base_link)}</code>, "
            f"ee_link = <code>{escape(self.ee_frame)}</code></p>"
            "<table><thead><tr><th>joint</th><th>type</th><th>axis</th><th>parent &rarr; child</th><th>lower</th>"
            f"<th>upper</th></tr></thead><tbody>{rows}</tbody></table>"
        )

    # ------------------------------------------------------------------
    # Frames
    # ------------------------------------------------------------------

    def frame(self, name: str) -> str:
        """The link name that ``name`` refers to, resolving ``base_link``/``world``/``ee_link``.

        Raises
        ------
        UnknownFrameError
            With the closest frame names.
        """
        if not isinstance(name, str):
            raise UnknownFrameError(f"robot '{self.name}': a frame is named by a string such as 'base_link' or "
                                    f"'ee_link', not {type(name).__name__} {repr_text(name)}")
        if name in self._frame_ids:
            return name
        if name in BASE_ALIASES:
            return self.root_link
        if name == EE_ALIAS:
            return self.ee_frame
        close = close_matches(name, self.frame_names, n=3, cutoff=0.5)
        hint = f"did you mean {', '.join(close)}? " if close else ""
        listed = ", ".join(self.frame_names[:15]) + (", ..." if len(self.frame_names) > 15 else "")
        raise UnknownFrameError(
            f"robot '{self.name}' has no frame {quoted_name(name, 200)}; {hint}frames: {listed} "
            f"(also base_link, ee_link; `manipkit frames` lists all)"
        )

    def frame_id(self, name: str) -> int:
        """Pinocchio frame index of a frame name or alias."""
        return self._frame_ids[self.frame(name)]

    def chain_joints(self, base: str, tip: str) -> tuple[str, ...]:
        """The joints of the serial chain *down* the link tree from ``base`` to ``tip``, base first (what a DH table
        reads): ``robot.chain(base, tip).joint_names`` when ``tip`` is below ``base``.

        Raises
        ------
        ChainError
            ``tip`` is not below ``base`` (the message says to swap them, or that they are on different
            branches); :meth:`chain` itself takes any two frames.
        """
        base_name, tip_name = self.frame(base), self.frame(tip)
        base_joint = self.model.frames[self.frame_id(base_name)].parentJoint
        tip_joint = self.model.frames[self.frame_id(tip_name)].parentJoint
        if base_joint not in self.model.supports[tip_joint]:
            if tip_joint in self.model.supports[base_joint]:
                hint = f"'{base_name}' is below '{tip_name}': swap them (base='{tip_name}', tip='{base_name}')"
            else:
                hint = f"they are on different branches; choose a base above '{tip_name}', such as '{self.base_link}'"
            raise ChainError(
                f"robot '{self.name}': tip '{tip_name}' is not below base '{base_name}' in the link tree "
                f"(a movable joint lies on the way up from '{base_name}'); {hint}"
            )
        return self.chain(base_name, tip_name).joint_names

    def sample_q(self, n: int, *, seed: int = 0) -> np.ndarray:
        """``n`` whole-robot joint vectors inside the limits: :meth:`JointSpace.sample
        <manipkit.kinematics.chain.JointSpace.sample>` (continuous joints: [-pi, pi]), shape (n, len(joint_names))."""
        return self.sample(n, seed=seed)

    # ------------------------------------------------------------------
    # Joint vectors
    # ------------------------------------------------------------------

    def q(self, values=None, /, *, degrees: bool = False, **joint_values) -> np.ndarray:
        """A joint vector from joint values: a sequence in joint order, a dict by name, or keywords.

        Parameters
        ----------
        values : sequence or dict, optional
            One value per entry of :attr:`joint_names`, in that order; or joint
            name -> value (names may also be given as keyword arguments). A
            floating joint takes its six values ``[x, y, z, roll, pitch, yaw]``
            under its own name (a planar joint ``[x, y, yaw]``), or one at a
            time as ``base_joint.x`` etc.
        degrees : bool, keyword-only
            Angular values are in degrees (prismatic ones stay in metres).

        Returns
        -------
        q : ndarray, shape (n,)
            In :attr:`joint_names` order; joints not given are 0, or the
            nearest value inside their limits.

        Raises
        ------
        JointValueError
            Unknown joint name (the valid ones are listed), a mimic joint (its
            leader is named), a value that is not a finite number, or a
            sequence of the wrong length.

        Notes
        -----
        Values outside the joint limits are accepted here (the pose such a
        value would give can still be computed). For a strict check use
        :meth:`check_limits` (raises :class:`JointLimitError` naming the
        joint, value and limits), :meth:`limit_violations` to list them, or
        :meth:`clamp` to move them to the nearest limit. :meth:`transform`
        and the command line are strict by default.

        Examples
        --------
        >>> robot = load("planar_2r")
        >>> robot.q(joint2=90, degrees=True)
        array([0.        , 1.57079633])
        >>> robot.q([0, 90], degrees=True)
        array([0.        , 1.57079633])
        """
        if values is not None and not isinstance(values, Mapping):
            if isinstance(values, (str, bytes)):
                raise JointValueError(f"robot.q takes joint values in joint order or by name, not the text {values!r}")
            if joint_values:
                raise JointValueError("give joint values either in joint order or by name, not both")
            q = self._check_q(values)
            if degrees:
                q = np.where([j.is_angular for j in self.joints], np.radians(q), q) if len(q) else q
            return np.array(q, dtype=float)
        twice = sorted(set(values or {}) & set(joint_values))
        if twice:
            raise JointValueError(f"joint '{twice[0]}' is given twice (in the dict and as a keyword); give each joint once")
        q = np.array([j.default() for j in self.joints], dtype=float)
        for name, value in dict(values or {}, **joint_values).items():
            for index, number in self._entries(name, value):
                q[index] = math.radians(number) if degrees and self.joints[index].is_angular else number
        return q

    def _entries(self, name, value) -> list[tuple[int, float]]:
        """(index in q, value) pairs for one named value of :meth:`q`, checked."""
        if name in self._coordinates:
            indices = self._coordinates[name]
            coordinates = ", ".join(self.joints[i].coordinate for i in indices)
            numbers = np.atleast_1d(np.asarray(value, dtype=object)).ravel() if not isinstance(value, str) else [value]
            if len(numbers) != len(indices):
                raise JointValueError(f"joint '{name}' is {self.joints[indices[0]].type}: give {len(indices)} values "
                                      f"({coordinates}), got {repr_text(value)}")
            return [(i, _joint_number(self.joints[i].name, v)) for i, v in zip(indices, numbers)]
        if name not in self._joint_index:
            if name in self.mimic_joints:
                mimic = self.mimic_joints[name]
                raise JointValueError(
                    f"joint '{name}' mimics '{mimic.leader}' ({short_text(mimic.multiplier)} x {mimic.leader} + "
                    f"{short_text(mimic.offset)}); give a value to '{mimic.leader}' instead"
                )
            close = close_matches(name, self.joint_names, n=1, cutoff=0.5)
            hint = f"did you mean {close[0]}? " if close else ""
            raise JointValueError(
                f"robot '{self.name}' has no joint {quoted_name(name, 200)}; {hint}joints: {', '.join(self.joint_names) or 'none'}"
            )
        return [(self._joint_index[name], _joint_number(name, value))]

    def as_dict(self, q) -> dict[str, float]:
        """Joint name -> value for a joint vector."""
        q = self._check_q(q)
        return {name: float(value) for name, value in zip(self.joint_names, q)}

    def rows(self, Q) -> np.ndarray:
        """Many whole-robot joint vectors (..., n) from ``Q``, checked (finite reals, one per joint); a dict by name is
        one vector, as :meth:`q` takes it."""
        if isinstance(Q, Mapping):
            return self.q(Q)
        Q = joint_array(Q)
        if Q.ndim == 0 or Q.shape[-1] != len(self.joints):
            raise JointValueError(f"robot '{self.name}' needs {len(self.joints)} joint values per configuration "
                                  f"({', '.join(self.joint_names) or 'none'}), got shape {Q.shape}")
        if not np.all(np.isfinite(Q)):
            raise JointValueError("joint values must be finite numbers")
        return Q

    def _checked(self, q) -> np.ndarray:
        return self._check_q(q)

    def _check_q(self, q) -> np.ndarray:
        """A joint vector from anything :meth:`q` takes (None: the default), checked for length and finiteness."""
        if type(q) is not np.ndarray:
            if isinstance(q, Mapping):
                return self.q(q)
            q = self.q() if q is None else joint_array(q)
        elif q.dtype != np.float64:
            q = joint_array(q)
        if q.shape != (len(self.joints),):
            raise JointValueError(
                f"robot '{self.name}' needs {len(self.joints)} joint values ({', '.join(self.joint_names)}), got shape {q.shape}"
            )
        if not np.isfinite(q).all():
            raise JointValueError("joint values must be finite numbers")
        return q

    def velocity_map(self) -> np.ndarray:
        """``S`` (model.nv, n): Pinocchio's velocity vector ``v = S qdot`` for joint rates in :attr:`joint_names` order.

        A mimic joint moves at its multiplier times its leader's rate, so a
        Pinocchio Jacobian ``J_pin`` (one column per URDF joint) becomes
        manipkit's as ``J_pin @ S``. Floating and planar joints have no such
        map (:class:`DescriptionError`).
        """
        return self._layout.velocity_map(self.model)

    def pinocchio_configuration(self, q) -> np.ndarray:
        """Pinocchio's configuration vector (size ``model.nq``) for a joint vector."""
        q = self._check_q(q)
        return self._layout.configuration(q)

    # ------------------------------------------------------------------
    # Kinematics
    # ------------------------------------------------------------------

    def transform(self, base: str | None = None, tip: str | None = None, q=None, *, check_limits: bool = True
                  ) -> np.ndarray:
        """T_base_tip: the pose of ``tip`` expressed in ``base``.

        Computed by Pinocchio's forward kinematics of the whole robot,
        ``oMf[base]^-1 oMf[tip]`` (one configuration: no compiled program to
        load, so ``tf-between`` starts without numba; the independent
        reference every test holds :meth:`Chain.fk
        <manipkit.kinematics.chain.Chain.fk>` to). Same direction as
        ``tf2_echo base tip`` and ``tf-between BASE TIP``.

        Parameters
        ----------
        base, tip : str
            Frame names (or the aliases ``base_link``, ``ee_link``); any two
            frames, on one branch or not.
        q : array_like or dict, optional
            Anything :meth:`q` takes: values in joint order, or by name
            (joints not given at their default); default: every joint at 0.
        check_limits : bool, keyword-only
            Refuse values outside the joint limits with :class:`JointLimitError`,
            as the command line does (default); False computes the pose the
            joints would have there.

        Returns
        -------
        T : ndarray, shape (4, 4)
        """
        source_id, target_id = self.frame_id(base), self.frame_id(tip)
        q = self.check_limits(q) if check_limits else self._check_q(q)
        data = self.data
        pin.framesForwardKinematics(self.model, data, self._layout.configuration(q))
        T_root_source = data.oMf[source_id]
        T_root_target = data.oMf[target_id]
        return (T_root_source.actInv(T_root_target)).homogeneous.copy()

    def jacobian(self, q=None, *, base: str | None = None, tip: str | None = None, reference: str = "base",
                 representation: str = "geometric") -> np.ndarray:
        """The frame Jacobian (6, n): :func:`manipkit.kinematics.jacobian.jacobian` (rows vx vy vz wx wy wz).

        ``reference="base"``: expressed in the base frame's axes (Pinocchio
        LOCAL_WORLD_ALIGNED when the base is the root, RTB ``jacob0``);
        ``"local"``: in the frame's own axes (Pinocchio LOCAL, RTB ``jacobe``).
        Columns follow :attr:`joint_names` (a mimic joint adds to its leader's);
        ``robot.chain(base, tip).jacobian(q)`` has the chain's columns only.
        Frames by keyword, ``base="base_link"``, ``tip="ee_link"`` by default.
        """
        from manipkit.kinematics.jacobian import jacobian

        q = None if q is None else self._check_q(q)
        return jacobian(self, q, base=base, tip=tip, reference=reference, representation=representation)

    def jacobians(self, Q, *, base: str | None = None, tip: str | None = None, reference: str = "base",
                  representation: str = "geometric") -> np.ndarray:
        """Frame Jacobians (N, 6, n) for many joint vectors: :func:`manipkit.kinematics.jacobian.jacobians` (compiled).

        Frames as :meth:`jacobian`.
        """
        from manipkit.kinematics.jacobian import jacobians

        return jacobians(self, Q, base=base, tip=tip, reference=reference, representation=representation)

    def visual_model(self, *, missing_meshes: str = "error") -> pin.GeometryModel:
        """The robot's ``<visual>`` geometry as a Pinocchio ``GeometryModel``.

        Mesh files (``package://``, ``file://`` or relative paths) are resolved
        by :func:`manipkit.description.meshes.visual_urdf` (``--package-dir``
        folders, the ROS workspace around the description, ``ROS_PACKAGE_PATH``,
        example-robot-data) before Pinocchio reads them.

        ``missing_meshes="draw"`` (what the viewer asks for) draws a link whose
        mesh files are absent by its primitive collision shapes, else as lines
        between joint origins, and issues one :class:`~manipkit.description.meshes.MissingMeshWarning`
        saying how many are missing and what is drawn instead.

        Raises
        ------
        PackageNotFoundError
            With ``missing_meshes="error"`` (the default), a mesh whose package
            or file cannot be found; the message names the URI, the link and the places searched.
        DescriptionError
            Pinocchio cannot read the resolved geometry.
        """
        import warnings

        from manipkit.description.meshes import MissingMeshWarning, visual_urdf
        from manipkit.kinematics.joints import native_call

        near = self.source.path if self.source.path.exists() else None
        resolver = PackageResolver(dict(self.package_dirs), near=near)
        policy = ReadPolicy(near, resolver, self.allow_read) if near is not None else None
        text, package_dirs, missing = visual_urdf(self.urdf, resolver, relative_to=self.source.path.parent,
                                                  missing=missing_meshes, policy=policy)
        if missing is not None:
            warnings.warn(missing.message(self.name), MissingMeshWarning, stacklevel=2)
        try:
            return native_call(pin.buildGeomFromUrdfString, self.model, text, pin.GeometryType.VISUAL,
                               package_dirs=package_dirs)[0]  # a sized stack; coal's raw lines captured
        except (ValueError, RuntimeError) as exc:
            raise DescriptionError(
                f"{self.name}: Pinocchio cannot load the visual geometry: {' '.join(str(exc).split())}"
            ) from None

    def geometry_placements(self, geometry_model: pin.GeometryModel, q=None) -> list[np.ndarray]:
        """T_root_geometry (4x4, m) of each object of ``geometry_model`` at ``q``, in its order.

        ``geometry_model`` comes from :meth:`visual_model`; the placements are
        Pinocchio's ``updateGeometryPlacements`` (its world frame is the root
        link). Mesh scale is not applied. Uses its own Pinocchio ``Data``, so
        it may run beside :meth:`transform` (the viewer's server thread).
        """
        data, geometry_data = self.model.createData(), geometry_model.createData()
        pin.updateGeometryPlacements(self.model, data, geometry_model, geometry_data, self.pinocchio_configuration(q))
        return [placement.homogeneous.copy() for placement in geometry_data.oMg]

    def fk(self, Q, *, base: str | None = None, tip: str | None = None) -> np.ndarray:
        """Poses of ``tip`` in ``base`` for many joint vectors at once: ``robot.chain(base, tip)``'s compiled FK.

        Parameters
        ----------
        Q : array_like, shape (..., n)
            Joint vectors in :attr:`joint_names` order (whole-robot rows).
        base, tip : str, keyword-only
            The frame the poses are expressed in (default ``base_link``, i.e.
            :attr:`base_link`, as everywhere else) and the frame posed
            (default ``ee_link``): any two frames (on different branches, the
            chain goes up from the base and down to the tip).

        Returns
        -------
        T_base_tip : ndarray, shape (..., 4, 4)

        Notes
        -----
        The chain's program (:class:`manipkit.kernels.fk.ChainFK`, equal to
        Pinocchio to about 1e-15) runs on the chain's columns of ``Q``.
        """
        chain = self.chain(self.base_link if base is None else base, EE_ALIAS if tip is None else tip)
        Q = joint_array(Q)
        if Q.shape[-1:] != (len(self.joints),):
            raise JointValueError(
                f"robot '{self.name}' needs {len(self.joints)} joint values per row ({', '.join(self.joint_names)}), "
                f"got shape {Q.shape}"
            )
        if not np.all(np.isfinite(Q)):
            raise JointValueError("joint values must be finite numbers")
        lead = Q.shape[:-1]
        flat = Q.reshape(math.prod(lead), len(self.joints))  # also for robots without movable joints
        return chain.program.fk.transforms(chain_columns(flat, chain.columns)).reshape(*lead, 4, 4)

    def chain(self, base: str, tip: str) -> Chain:
        """The :class:`~manipkit.kinematics.chain.Chain` of the joints that move ``tip`` relative to ``base``.

        Built once per (base, tip) and shared: the same call returns the same
        immutable object. Frames in the order of ``tf-between SOURCE TARGET``
        (base first); aliases ``base_link`` and ``ee_link`` allowed. Any two
        frames make a chain: the base above the tip, below it, or on another
        branch (then the chain goes up from the base to the link where the
        branches meet and down to the tip: finger to finger); equal frames,
        or frames with only fixed joints between them, give a chain with no
        joints.

        Parameters
        ----------
        base, tip : str
            Link names.

        Raises
        ------
        UnknownFrameError
            A frame the robot does not have.

        Examples
        --------
        >>> robot = load("planar_2r")
        >>> robot.chain("base_link", "ee_link").joint_names
        ('joint1', 'joint2')
        >>> [step.index for step in robot.chain("base_link", "ee_link").steps]
        [0, 1, -1]
        """
        key = (self.frame(base), self.frame(tip))
        chain = self._chain_objects.get(key)
        if chain is None:
            frame_id = self.frame_id(key[1])
            base_id = None if key[0] == self.root_link else self.frame_id(key[0])
            steps = tuple(chain_steps(self.model, self._layout.columns, frame_id, base_id))
            chain = self._chain_objects.setdefault(key, Chain(self, key[0], key[1], steps))
        return chain


def _joint_number(name: str, value) -> float:
    """``value`` as a finite real number, or :class:`JointValueError` naming the joint."""
    try:
        if isinstance(value, (complex, np.complexfloating)):
            raise TypeError("complex")  # float() would drop the imaginary part (or refuse it)
        number = float(value)
    except (TypeError, ValueError):
        raise JointValueError(f"joint '{name}': value '{value}' is not a number") from None
    if not math.isfinite(number):
        raise JointValueError(f"joint '{name}': value {value} is not finite; give a finite number")
    return number
