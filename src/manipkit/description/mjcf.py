"""MuJoCo MJCF descriptions read through MuJoCo's own compiler, written out as URDF text.

The route: the file is compiled by MuJoCo (PyPI ``mujoco``, ``MjSpec``), which
resolves ``<include>``, ``<default>`` classes, ``childclass``, ``<frame>``,
``angle="degree"``, ``eulerseq``, every orientation form (quat, axisangle,
euler, xyaxes, zaxis) and joint ``ref`` exactly as a MuJoCo user sees them; the
compiled ``MjModel``'s bodies are then written out as URDF text
(:func:`mjcf_urdf`), which the URDF pipeline (validation, Pinocchio, the tool
frame, collisions, the viewer) reads unchanged. URDF text was chosen over
building a Pinocchio model directly so that every command, the validator's
checks and the mesh fallbacks of the viewer work on an MJCF arm with no
second code path; Pinocchio's own MJCF parser is not used (4.1 crashes on
``<include>`` and drops ``<frame>`` subtrees).

How the compiled model maps to URDF (conventions: metres, radians; MuJoCo
quaternions are (w, x, y, z), URDF ``rpy`` is R = Rz(yaw) Ry(pitch) Rx(roll)):

- Links are the bodies (``world`` is the root link; an unnamed body is
  ``body<ID>``), and each named site is a link on a fixed joint at the site's
  pose (a site whose name a body has is ``<NAME>_site``).
- A body without joints hangs on a fixed joint at its ``body_pos``/``body_quat``.
  A body's hinge or slide joints move it as ``mj_kinematics`` does: in the body's
  frame, joint i applies ``Trans(p_i) Rot(a_i, q_i - ref_i) Trans(-p_i)`` (hinge, axis
  ``a_i`` through ``jnt_pos`` ``p_i``) or ``Trans(a_i (q_i - ref_i))`` (slide), in order.
  So a URDF joint's origin is ``T(body_pos, body_quat) Trans(p_1) Rot(a_1, -ref_1)``
  (the next one ``Trans(p_i - p_{i-1}) Rot(a_i, -ref_i)``), and when the last joint is
  not at the body origin a fixed joint ``Trans(-p_k)`` follows; links between are
  named ``<BODY>__<JOINT>``. The joint's value is MuJoCo's ``qpos``.
- A limited hinge is ``revolute`` with ``jnt_range``, an unlimited one
  ``continuous``; a slide is ``prismatic`` (an unlimited slide is refused: URDF
  needs limits). A ``free`` joint of a top-level body is a URDF ``floating``
  joint at the world origin (its six values are the body's pose in the world,
  as MuJoCo's qpos is); a ``ball`` joint is refused in one line.
- Inertials are the compiled ``body_mass``, ``body_ipos``, ``body_iquat``, ``body_inertia``.
- Geoms: every geom of groups 0-2 (MuJoCo's visible groups) is a ``<visual>``;
  every geom with ``contype`` or ``conaffinity`` set is a ``<collision>``. Sphere,
  box, cylinder and capsule keep their shapes (sizes doubled where URDF takes
  full lengths); an ellipsoid becomes the sphere of its largest semi-axis (it
  encloses the ellipsoid); planes and height fields are left out. A mesh geom
  whose file is there is the file (its pose undoes the compiler's re-centring,
  ``mesh_pos``/``mesh_quat``); a missing mesh file is replaced by a small sphere
  before compiling and written to the URDF as the missing file, so the URDF
  pipeline warns about it and the viewer draws the link another way, as for URDF.
- The pairs MuJoCo never tests for contact (``contype``/``conaffinity`` bits
  never meeting, parent and child bodies, ``<exclude>``; a ``<pair>`` is always
  tested) are :func:`mjcf_disabled_pairs`, in the form the collision checks take
  as ``srdf=``; they are a robot loaded from MJCF's default disabled pairs
  (:func:`mjcf_rules`, as the SRDF a URDF ships), and the outputs name them
  (:func:`rules_source_text`). A geom a ``<pair>`` names is collision geometry
  even with ``contype`` and ``conaffinity`` 0.

Read limits, as for URDF (:mod:`manipkit.description.access`): before MuJoCo
opens anything, every ``<include>`` (and ``<model>`` asset) file is found,
checked with :func:`manipkit.inputs.check_input_file` and must lie inside
what the description may read; the files together are bounded by
:data:`MAX_MJCF_FILES` and :data:`manipkit.inputs.MAX_DESCRIPTION_BYTES`, and the
bodies they make (``<replicate>`` copies counted) by :data:`MAX_MJCF_BODIES`; a mesh
file outside is refused; texture, height-field and skin files are dropped
unread. Compiler errors become one line naming the file.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from manipkit.errors import DescriptionError, InputFileError, ReadNotAllowedError
from manipkit.inputs import MAX_DESCRIPTION_BYTES, check_input_file
from manipkit.spatial.rotations import matrix_from_axis_angle, rpy_from_matrix
from manipkit.spatial.transforms import transform_from_xyz_quaternion

__all__ = [
    "MAX_MJCF_BODIES", "MAX_MJCF_FILES", "compile_mjcf", "is_mjcf", "mjcf_disabled_pairs", "mjcf_files", "mjcf_locator",
    "mjcf_rules", "mjcf_urdf", "rules_source_text",
]

#: Most files (the top file and its includes) one MJCF description may read.
MAX_MJCF_FILES = 200
#: Most bodies an MJCF description may make, counting each ``<replicate count="N">`` copy (arms have tens,
#: scenes hundreds; nested replicates multiply, so a small file could ask the compiler for millions).
MAX_MJCF_BODIES = 10_000
#: Radius (m) of the sphere a missing mesh is replaced by before compiling (its pose is all that is kept).
_PLACEHOLDER_RADIUS = 1e-3
_MARK = "manipkit_missing_mesh_"


def is_mjcf(path: str | os.PathLike) -> bool:
    """Whether ``path`` names an MJCF file: a ``.xml`` file whose root element is ``<mujoco>``.

    >>> is_mjcf("arm.urdf")
    False
    """
    path = Path(path)
    if path.suffix != ".xml" or not path.is_file():
        return False
    return _root_tag(path) == "mujoco"


def _root_tag(path: Path) -> str | None:
    from lxml import etree

    try:
        check_input_file(path, what="robot file", max_bytes=MAX_DESCRIPTION_BYTES)
        for _, element in etree.iterparse(str(path), events=("start",), resolve_entities=False, no_network=True):
            return etree.QName(element).localname
    except (etree.XMLSyntaxError, OSError, InputFileError):
        return None
    return None


def mjcf_files(path: str | os.PathLike, *, allow_read=()) -> list[Path]:
    """The MJCF file and every file its ``<include file>`` (and ``<model file>``) elements name, checked.

    Include paths are relative to the top file's folder, as MuJoCo resolves
    them. Each file must be a regular file of at most
    :data:`~manipkit.inputs.MAX_DESCRIPTION_BYTES` inside what the description
    may read; the files together at most :data:`MAX_MJCF_FILES` and
    :data:`~manipkit.inputs.MAX_DESCRIPTION_BYTES`.

    Raises
    ------
    ReadNotAllowedError, InputFileError, DescriptionError
        One line naming the including file and the file.
    """
    from lxml import etree

    from manipkit.description.access import ReadPolicy

    top = Path(os.path.abspath(path))
    policy = ReadPolicy(top, None, allow_read)
    files, todo, total, bodies = [top], [top], 0, 0
    parser = etree.XMLParser(remove_comments=True, resolve_entities=False, no_network=True, huge_tree=False)
    while todo:
        current = todo.pop()
        check_input_file(current, what="MJCF file", max_bytes=MAX_DESCRIPTION_BYTES)
        total += current.stat().st_size
        if total > MAX_DESCRIPTION_BYTES:
            raise DescriptionError(f"{top.name}: its files together exceed {MAX_DESCRIPTION_BYTES} bytes "
                                   f"(at {current.name}); a robot description is far smaller")
        try:
            root = etree.parse(str(current), parser).getroot()
        except etree.XMLSyntaxError as exc:
            raise DescriptionError(f"{current.name}:{exc.lineno}: malformed XML: {exc.msg}") from None
        bodies += _body_count(root, current.name, bodies)
        for element in root.iter("include", "model"):
            name = element.get("file")
            if not name:
                continue
            included = Path(os.path.abspath(top.parent / name))
            where = f"{current.name}:{element.sourceline}: <{element.tag} file=\"{name}\">"
            try:
                policy.check(included, f"{where}")
            except ReadNotAllowedError as exc:
                raise ReadNotAllowedError(str(exc)) from None
            if not included.exists():
                raise DescriptionError(f"{where}: no such file {included}")
            if included in files:
                if element.tag == "include":
                    raise DescriptionError(f"{where}: {included.name} is included twice (or includes itself); "
                                           "MuJoCo refuses repeated includes")
                continue
            try:
                check_input_file(included, what="robot file", max_bytes=MAX_DESCRIPTION_BYTES)
            except InputFileError as exc:
                raise InputFileError(f"{where}: {exc}") from None
            files.append(included)
            todo.append(included)
            if len(files) > MAX_MJCF_FILES:
                raise DescriptionError(f"{top.name}: more than {MAX_MJCF_FILES} included files")
    return files


def _body_count(root, where: str, before: int) -> int:
    """The bodies ``root`` makes (each ``<replicate>`` copy counted), or a one-line error above :data:`MAX_MJCF_BODIES`."""
    total = 0
    for body in root.iter("body"):
        copies = 1
        for ancestor in body.iterancestors("replicate"):
            try:
                copies *= max(int(ancestor.get("count", "1")), 1)
            except ValueError:
                continue  # not a number: the compiler's error
        total += copies
        if before + total > MAX_MJCF_BODIES:
            replicated = f" (<replicate> at line {next(body.iterancestors('replicate')).sourceline} makes {copies} copies)" \
                if copies > 1 else ""
            raise DescriptionError(f"{where}:{body.sourceline}: more than {MAX_MJCF_BODIES} bodies{replicated}; "
                                   "manipkit reads robots, which have tens")
    return total


def mjcf_locator(path: str | os.PathLike, *, allow_read=()):
    """``locate(tag, name)`` for :func:`manipkit.description.validate.check_urdf`: where a link or joint is written.

    A URDF link is an MJCF ``<body>`` or ``<site>``, a URDF joint a ``<joint>`` or
    ``<freejoint>`` of that name; the answer is ``"FILE.xml:LINE"`` in the file
    or its includes, or None (an unnamed body, a joint manipkit added).
    """
    import re

    try:
        files = mjcf_files(path, allow_read=allow_read)
    except (DescriptionError, InputFileError, ReadNotAllowedError, OSError):
        files = []
    texts = {file: file.read_text(encoding="utf-8", errors="replace") for file in files}
    tags = {"link": ("body", "site"), "joint": ("joint", "freejoint")}

    def locate(tag: str, name: str) -> str | None:
        pattern = re.compile(rf"<(?:{'|'.join(tags.get(tag, (tag,)))})\b[^>]*\bname\s*=\s*[\"']{re.escape(name)}[\"']")
        for file, text in texts.items():
            found = pattern.search(text)
            if found:
                return f"{file.name}:{text.count(chr(10), 0, found.start()) + 1}"
        return None

    return locate


def compile_mjcf(path: str | os.PathLike, *, allow_read=()):
    """MuJoCo's compiled model of an MJCF file, with missing mesh files replaced (module docstring).

    Returns
    -------
    model : mujoco.MjModel
    missing : dict
        Geom name (as compiled) -> (mesh file path, scale (3,)) of each geom whose mesh file is missing.
    present : dict
        Mesh name -> the file MuJoCo read it from.

    Raises
    ------
    DescriptionError, ReadNotAllowedError, InputFileError
        One line naming the file: a compiler error, an include or mesh outside the folder, a file too large.
    """
    import mujoco

    from manipkit.description.access import ReadPolicy
    from manipkit.description.meshes import check_mesh_file

    path = Path(os.path.abspath(path))
    mjcf_files(path, allow_read=allow_read)
    policy = ReadPolicy(path, None, allow_read)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise DescriptionError(f"{path.name}: MuJoCo cannot read it: {_one_line(exc)}") from None
    missing: dict[str, tuple[str, np.ndarray]] = {}
    present: dict[str, str] = {}
    for mesh in list(spec.meshes):
        file = _asset_path(spec, path, mesh.file, spec.meshdir)
        if file is None:
            continue  # a mesh given by vertices in the file
        if file.is_file():
            policy.check(file, f"{path.name}: mesh '{mesh.name}'")
            check_input_file(file, what="mesh file", max_bytes=MAX_DESCRIPTION_BYTES)
            check_mesh_file(file, f"{path.name}: mesh '{mesh.name}'", policy)  # and the files it names
            present[mesh.name] = str(file)
            continue
        for geom in spec.geoms:
            if geom.meshname == mesh.name and geom.type == mujoco.mjtGeom.mjGEOM_MESH:
                if not geom.name:
                    geom.name = f"{_MARK}{len(missing)}"
                missing[geom.name] = (str(file), np.array(mesh.scale, dtype=float))
                geom.type = mujoco.mjtGeom.mjGEOM_SPHERE
                geom.size = [_PLACEHOLDER_RADIUS, 0.0, 0.0]
                geom.meshname = ""
        spec.delete(mesh)
    _drop_unread_assets(spec)
    try:
        model = spec.compile()
    except ValueError as exc:
        raise DescriptionError(f"{path.name}: MuJoCo compiler: {_one_line(exc)}") from None
    return model, missing, present


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()).removeprefix("Error: ") or type(exc).__name__


def _asset_path(spec, path: Path, file: str, folder: str) -> Path | None:
    """The file MuJoCo opens for an asset: absolute as given, else under the model's folder and ``folder``."""
    if not file:
        return None
    given = Path(file)
    if given.is_absolute():
        return given
    base = Path(folder) if folder and Path(folder).is_absolute() else Path(spec.modelfiledir or path.parent) / (folder or "")
    return Path(os.path.abspath(base / given))


def _drop_unread_assets(spec) -> None:
    """Textures, height fields and skins from files: kinematics do not need them, so they are not read."""
    import mujoco

    for texture in list(spec.textures):
        if texture.file or any(texture.cubefiles):
            spec.delete(texture)
    for material in spec.materials:
        material.textures = [""] * len(material.textures)
    for field in list(spec.hfields):
        if field.file:
            for geom in list(spec.geoms):
                if geom.type == mujoco.mjtGeom.mjGEOM_HFIELD and geom.hfieldname == field.name:
                    spec.delete(geom)
            spec.delete(field)
    for skin in list(spec.skins):
        spec.delete(skin)


# --------------------------------------------------------------------------
# The compiled model as URDF
# --------------------------------------------------------------------------


def _name(model, kind, index: int) -> str:
    import mujoco

    return mujoco.mj_id2name(model, kind, index) or ""


def body_names(model) -> list[str]:
    """Link name of each body: its name, else ``body<ID>`` (the world body is ``world``)."""
    import mujoco

    names = [_name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}" for b in range(model.nbody)]
    names[0] = names[0] or "world"
    return names


def _transform(position, quaternion_wxyz=(1.0, 0.0, 0.0, 0.0)) -> np.ndarray:
    """4x4 transform of a MuJoCo position and quaternion (w, x, y, z)."""
    w, x, y, z = quaternion_wxyz
    return transform_from_xyz_quaternion(position, (x, y, z, w))


def _axis_rotation(axis, angle: float) -> np.ndarray:
    """The 4x4 rotation by ``angle`` (rad) about ``axis``."""
    T = np.eye(4)
    T[:3, :3] = matrix_from_axis_angle(axis, angle)
    return T


def _origin(T: np.ndarray) -> dict[str, str]:
    """URDF ``<origin xyz rpy>`` of a 4x4 transform (rpy: R = Rz(yaw) Ry(pitch) Rx(roll)).

    ``gimbal_tol=0``: the angles reproduce the rotation to rounding error next to the lock too.
    """
    return {"xyz": _numbers(T[:3, 3]), "rpy": _numbers(rpy_from_matrix(T[:3, :3], check=False, gimbal_tol=0.0))}


def _numbers(values) -> str:
    return " ".join(repr(float(v) + 0.0) for v in values)


def mjcf_urdf(path: str | os.PathLike, *, allow_read=()) -> str:
    """URDF text of an MJCF file, by the mapping of the module docstring.

    Parameters
    ----------
    path : path-like
        The ``.xml`` MJCF file (a ``.xml`` whose root is ``<robot>`` is returned as its own text).
    allow_read : tuple of Path
        Folders the description may read besides its own (``--allow-read``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> arm = pathlib.Path(tempfile.mkdtemp()) / "arm.xml"
    >>> _ = arm.write_text('<mujoco><worldbody><body name="a"><joint name="j" range="-1 1"/>'
    ...                    '<geom size=".1"/></body></worldbody></mujoco>')
    >>> 'type="revolute"' in mjcf_urdf(arm)
    True
    """
    path = Path(path)
    if _root_tag(path) == "robot":
        return path.read_text(encoding="utf-8-sig")
    model, missing, present = compile_mjcf(path, allow_read=allow_read)
    return _urdf_of(model, missing, present, path.name, path.stem)


def _urdf_of(model, missing: dict, present: dict, where: str, name: str) -> str:
    import xml.etree.ElementTree as ET

    import mujoco

    robot = ET.Element("robot", name=bytes(model.names).split(b"\0", 1)[0].decode("utf-8", "replace") or name)
    links = body_names(model)
    joint_names: set[str] = set()
    link_elements = {}
    for b, link in enumerate(links):
        link_elements[b] = ET.SubElement(robot, "link", name=link)
        if b and model.body_mass[b] > 0:
            _inertial(link_elements[b], model, b)

    def joint(kind: str, jname: str, parent: str, child: str, T: np.ndarray) -> ET.Element:
        base, k = jname, 1
        while jname in joint_names:
            jname, k = f"{base}_{k}", k + 1
        joint_names.add(jname)
        element = ET.SubElement(robot, "joint", name=jname, type=kind)
        ET.SubElement(element, "origin", **_origin(T))
        ET.SubElement(element, "parent", link=parent)
        ET.SubElement(element, "child", link=child)
        return element

    for b in range(1, model.nbody):
        parent = links[model.body_parentid[b]]
        T = _transform(model.body_pos[b], model.body_quat[b])
        first, count = int(model.body_jntadr[b]), int(model.body_jntnum[b])
        if count == 0:
            joint("fixed", f"{links[b]}_fixed", parent, links[b], T)
            continue
        previous = np.zeros(3)
        for k, j in enumerate(range(first, first + count)):
            jname = _name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"{links[b]}_joint{k}"
            kind = int(model.jnt_type[j])
            if kind == mujoco.mjtJoint.mjJNT_BALL:
                raise DescriptionError(f"{where}: joint '{jname}' of body '{links[b]}' is a ball joint; manipkit "
                                       "reads hinge, slide and free joints (make it three hinges, or remove it)")
            if kind == mujoco.mjtJoint.mjJNT_FREE:
                if count > 1 or model.body_parentid[b] != 0:
                    raise DescriptionError(f"{where}: free joint '{jname}' of body '{links[b]}' is not the only "
                                           "joint of a top-level body; manipkit reads a free joint only there")
                joint("floating", jname, parent, links[b], np.eye(4))
                break
            p = np.array(model.jnt_pos[j], dtype=float)
            axis = np.array(model.jnt_axis[j], dtype=float)
            ref = float(model.qpos0[model.jnt_qposadr[j]])
            shift = _axis_rotation(axis, -ref) if kind == mujoco.mjtJoint.mjJNT_HINGE else _transform(-ref * axis)
            T = T @ _transform(p - previous) @ shift
            last = k == count - 1
            child = links[b] if last and not p.any() else f"{links[b]}__{jname}"
            limited = bool(model.jnt_limited[j])
            if kind == mujoco.mjtJoint.mjJNT_SLIDE and not limited:
                raise DescriptionError(f"{where}: slide joint '{jname}' has no range; give it range=\"LOW HIGH\" "
                                       "(URDF, and manipkit, need a prismatic joint's limits)")
            urdf_kind = "prismatic" if kind == mujoco.mjtJoint.mjJNT_SLIDE else "revolute" if limited else "continuous"
            element = joint(urdf_kind, jname, parent, child, T)
            ET.SubElement(element, "axis", xyz=_numbers(axis))
            if urdf_kind != "continuous":
                low, high = model.jnt_range[j]
                ET.SubElement(element, "limit", lower=repr(float(low)), upper=repr(float(high)),
                              effort="0", velocity="0")
            else:
                ET.SubElement(element, "limit", effort="0", velocity="0")
            if child != links[b]:
                ET.SubElement(robot, "link", name=child)
                parent = child
            if last and p.any():
                joint("fixed", f"{jname}_to_{links[b]}", child, links[b], _transform(-p))
            previous, T = p, np.eye(4)
    _sites(robot, model, links, joint)
    _geoms(link_elements, model, missing, present)
    return ET.tostring(robot, encoding="unicode")


def _inertial(link, model, b: int) -> None:
    import xml.etree.ElementTree as ET

    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", **_origin(_transform(model.body_ipos[b], model.body_iquat[b])))
    ET.SubElement(inertial, "mass", value=repr(float(model.body_mass[b])))
    ixx, iyy, izz = (float(v) for v in model.body_inertia[b])
    ET.SubElement(inertial, "inertia", ixx=repr(ixx), iyy=repr(iyy), izz=repr(izz), ixy="0", ixz="0", iyz="0")


def _sites(robot, model, links: list[str], joint) -> None:
    import xml.etree.ElementTree as ET

    import mujoco

    taken = set(links)
    for s in range(model.nsite):
        name = _name(model, mujoco.mjtObj.mjOBJ_SITE, s)
        if not name:
            continue
        if name in taken:
            name = f"{name}_site"
        taken.add(name)
        ET.SubElement(robot, "link", name=name)
        joint("fixed", f"{name}_fixed", links[model.site_bodyid[s]], name,
              _transform(model.site_pos[s], model.site_quat[s]))


def _geoms(link_elements: dict, model, missing: dict, present: dict) -> None:
    import xml.etree.ElementTree as ET

    import mujoco

    G = mujoco.mjtGeom
    for g in range(model.ngeom):
        kind, size = int(model.geom_type[g]), model.geom_size[g]
        T = _transform(model.geom_pos[g], model.geom_quat[g])
        gname = _name(model, mujoco.mjtObj.mjOBJ_GEOM, g)
        if gname in missing:
            shape = ("mesh", {"filename": missing[gname][0], "scale": _numbers(missing[gname][1])})
        elif kind == G.mjGEOM_MESH:
            mesh = model.geom_dataid[g]
            T = T @ np.linalg.inv(_transform(model.mesh_pos[mesh], model.mesh_quat[mesh]))
            shape = ("mesh", {"filename": present.get(_name(model, mujoco.mjtObj.mjOBJ_MESH, mesh), ""), "scale": _numbers(model.mesh_scale[mesh])})
        elif kind == G.mjGEOM_SPHERE:
            shape = ("sphere", {"radius": repr(float(size[0]))})
        elif kind == G.mjGEOM_ELLIPSOID:
            shape = ("sphere", {"radius": repr(float(max(size)))})
        elif kind == G.mjGEOM_BOX:
            shape = ("box", {"size": _numbers(2 * size)})
        elif kind in (G.mjGEOM_CYLINDER, G.mjGEOM_CAPSULE):
            shape = ("cylinder", {"radius": repr(float(size[0])), "length": repr(float(2 * size[1]))})
        else:
            continue  # a plane, height field or signed-distance field: no URDF form
        pieces = [(T, shape)]
        if kind == G.mjGEOM_CAPSULE:  # urdfdom has no capsule: the cylinder and a sphere on each end, exactly
            ball = ("sphere", {"radius": repr(float(size[0]))})
            pieces += [(T @ _transform((0.0, 0.0, side * size[1])), ball) for side in (-1.0, 1.0)]
        roles = []
        if model.geom_group[g] <= 2:
            roles.append("visual")
        if model.geom_contype[g] or model.geom_conaffinity[g] or _in_pair(model, g):
            roles.append("collision")
        for role in roles:
            for T_piece, (tag, attributes) in pieces:
                element = ET.SubElement(link_elements[model.geom_bodyid[g]], role)
                ET.SubElement(element, "origin", **_origin(T_piece))
                ET.SubElement(ET.SubElement(element, "geometry"), tag, **attributes)


def mjcf_disabled_pairs(model, *, allow_read=()) -> dict[tuple[str, str], str]:
    """Body pairs (sorted link names) MuJoCo never tests for contact, with the reason.

    ``model`` is a compiled ``mujoco.MjModel`` or the path of an MJCF file (compiled by
    :func:`compile_mjcf`). The answer is what ``srdf=`` of
    :class:`manipkit.kinematics.collisions.CollisionChecker` and
    :func:`manipkit.kinematics.collisions.collisions` take; for a robot loaded from
    MJCF it is the default (:func:`mjcf_rules`, :attr:`Robot.srdf <manipkit.kinematics.robot.Robot>`).

    MuJoCo's rule (``mj_collision``): two geoms are tested when
    ``(contype_a & conaffinity_b) or (contype_b & conaffinity_a)``, their bodies are
    not welded together (no joint between them), not parent and child (``filterparent``,
    on unless ``<option><flag filterparent="disable">``; the world's children excepted:
    MuJoCo compares weld bodies, and a body welded to the world is never filtered as a
    child) and no ``<contact><exclude>`` names the two bodies. A ``<contact><pair>`` is
    tested whatever those rules say; with ``<flag contact="disable">`` or
    ``constraint="disable"`` nothing is. A body pair is tested when some pair of their
    geoms is (the collision check then tests every geom of the two links: at least what
    MuJoCo does). Bodies without colliding geoms are left out.

    >>> import mujoco
    >>> m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><body name="a"><joint/><geom size=".1"/>'
    ...     '<body name="b"><joint/><geom size=".1"/></body></body></worldbody></mujoco>')
    >>> mjcf_disabled_pairs(m)
    {('a', 'b'): 'parent and child bodies'}
    """
    import mujoco

    if isinstance(model, (str, os.PathLike)):
        model = compile_mjcf(model, allow_read=allow_read)[0]
    links = body_names(model)
    paired = {tuple(sorted((int(model.geom_bodyid[g1]), int(model.geom_bodyid[g2]))))
              for g1, g2 in zip(model.pair_geom1, model.pair_geom2)}
    colliding: dict[int, list[tuple[int, int]]] = {}
    for g in range(model.ngeom):
        if model.geom_contype[g] or model.geom_conaffinity[g] or _in_pair(model, g):
            colliding.setdefault(int(model.geom_bodyid[g]), []).append(
                (int(model.geom_contype[g]), int(model.geom_conaffinity[g])))
    excluded = {tuple(sorted((int(b1), int(b2)))) for b1, b2 in
                zip(model.exclude_signature >> 16, model.exclude_signature & 0xFFFF)} if model.nexclude else set()
    flags = mujoco.mjtDisableBit
    no_contacts = model.opt.disableflags & (flags.mjDSBL_CONTACT | flags.mjDSBL_CONSTRAINT)
    filterparent = not (model.opt.disableflags & flags.mjDSBL_FILTERPARENT)
    weld = [int(w) for w in model.body_weldid]
    weld_parent = [weld[int(model.body_parentid[w])] for w in weld]
    pairs = {}
    bodies = sorted(colliding)
    for i, a in enumerate(bodies):
        for b in bodies[i + 1:]:
            key = tuple(sorted((links[a], links[b])))
            wa, wb = weld[a], weld[b]
            if no_contacts:
                pairs[key] = "contacts disabled (<option><flag contact/constraint=\"disable\">)"
            elif (a, b) in paired:
                continue  # an explicit <contact><pair>: tested whatever the filters say
            elif wa == wb:
                pairs[key] = "rigidly attached (no joint between them)"
            elif (a, b) in excluded:
                pairs[key] = "<exclude> in the description"
            elif filterparent and wa and wb and (weld_parent[b] == wa or weld_parent[a] == wb):
                pairs[key] = "parent and child bodies"
            elif not any(ta & cb or tb & ca for ta, ca in colliding[a] for tb, cb in colliding[b]):
                pairs[key] = "contype/conaffinity never meet"
    return pairs


def _in_pair(model, g: int) -> bool:
    """Whether geom ``g`` is named by a ``<contact><pair>`` (then it collides whatever its contype/conaffinity)."""
    return bool(model.npair) and bool(np.any(model.pair_geom1 == g) or np.any(model.pair_geom2 == g))


def mjcf_rules(path: str | os.PathLike, robot: str, *, allow_read=()):
    """The allowed-collision pairs of the MJCF file ``path`` (:func:`mjcf_disabled_pairs`) as an
    :class:`~manipkit.description.srdf.Srdf` of :attr:`~manipkit.description.srdf.Srdf.kind` ``"mjcf"``
    for robot ``robot``: no tips, its pairs sorted. A robot loaded from MJCF takes these as its default
    disabled pairs, as a URDF robot takes the SRDF it ships."""
    from manipkit.description.srdf import Srdf

    pairs = mjcf_disabled_pairs(path, allow_read=allow_read)
    return Srdf(Path(path), robot, tuple(sorted((a, b, reason) for (a, b), reason in pairs.items())), (),
                kind="mjcf")


def rules_source_text(source: str) -> str:
    """Where disabled pairs came from, in words: ``source`` is a file (an SRDF, or an MJCF whose rules
    :func:`mjcf_disabled_pairs` reads) or ``""`` (none: ``""``). The one wording of the outputs.

    >>> rules_source_text("arm.srdf")
    'SRDF arm.srdf'
    """
    from manipkit.text import printable

    if not source:
        return ""
    if is_mjcf(source):
        return f"the MJCF's contype/conaffinity and <exclude> rules ({printable(Path(source).name)})"
    return f"SRDF {printable(source)}"
