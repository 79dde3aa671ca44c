"""Fuzzing the hostile-input classes of issue 40: collision mesh vertices, world files, namespaced URDF.

Run with the other fuzzers by ``make fuzz`` (``MANIPKIT_FUZZ_EXAMPLES`` cases each, fresh randomness);
``make test`` runs 30 of each, deterministic. The oracles:

- mesh vertices (a binary STL of random triangles: NaN, inf, huge, tiny, flat, a zero scale): building the
  collision geometry and checking it raises a one-line :class:`ManipkitError` or gives a finite distance
  equal in both geometries when the mesh is flat (kept as triangles in both); never a crash (a segfault
  ends the run: that is the finding);
- world files (random YAML: numbers as text, huge integers, names with controls, nesting, aliases):
  :func:`read_world` raises a one-line :class:`ManipkitError` or gives obstacles whose names are one
  printable line of at most 100 characters and whose sizes and positions are finite and within 1e6;
- namespaced URDF (``xmlns="urn:x"`` put on random elements of a small arm, with a random defect): loading
  ends exactly as loading the same text without the namespaces does (the same message, or the same joints,
  limits and frames), since Pinocchio reads both alike.
"""

from __future__ import annotations

import math
import os
import re
import struct
from datetime import timedelta
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import manipkit
from manipkit.errors import ManipkitError
from manipkit.kinematics.collisions import CollisionChecker
from manipkit.kinematics.world import world_obstacles

EXAMPLES = int(os.environ.get("MANIPKIT_FUZZ_EXAMPLES", "30"))
FUZZING = "MANIPKIT_FUZZ_EXAMPLES" in os.environ
SETTINGS = settings(max_examples=EXAMPLES, deadline=timedelta(seconds=20), derandomize=not FUZZING,
                    database=settings.default.database if FUZZING else None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
ARM = (Path(__file__).parent / "bad_inputs" / "descriptions" / "good_arm.urdf").read_text()
CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029]")


def _one_line(exc: ManipkitError) -> None:
    message = str(exc)
    assert message and "\n" not in " ".join(message.split()) and len(message) < 5000, message[:300]


# --- mesh vertices -----------------------------------------------------------------------------------

COORDINATE = st.one_of(st.floats(-1.0, 1.0), st.sampled_from([0.0, math.nan, math.inf, -math.inf, 1e30, 1e-30]),
                       st.floats(allow_nan=True, allow_infinity=True, width=32))
VERTEX = st.tuples(COORDINATE, COORDINATE, COORDINATE)


def _stl(triangles) -> bytes:
    body = b"".join(struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *v) for v in t) + b"\0\0"
                    for t in triangles)
    return b"\0" * 80 + struct.pack("<I", len(triangles)) + body


@SETTINGS
@given(triangles=st.lists(st.tuples(VERTEX, VERTEX, VERTEX), min_size=1, max_size=30),
       flat_axis=st.sampled_from([None, 0, 1, 2]),
       scale=st.sampled_from(["1 1 1", "0 0 0", "1 1 0", "1e-12 1 1", "1000 1000 1000"]))
def test_fuzzed_collision_mesh_vertices_never_crash(tmp_path_factory, triangles, flat_axis, scale):
    folder = tmp_path_factory.mktemp("mesh")
    if flat_axis is not None:
        triangles = [tuple(tuple(0.0 if i == flat_axis else c for i, c in enumerate(v)) for v in t) for t in triangles]
    (folder / "m.stl").write_bytes(_stl(triangles))
    text = ARM.replace('<link name="base_link"/>', '<link name="base_link"><collision><geometry><box size="0.2 0.2 '
                       '0.05"/></geometry></collision></link>').replace(
        '<link name="upper_arm"/>', f'<link name="upper_arm"><collision><geometry><mesh filename="m.stl" '
        f'scale="{scale}"/></geometry></collision></link>')
    (folder / "arm.urdf").write_text(text)
    try:
        robot = manipkit.load(folder / "arm.urdf")
        reports = [CollisionChecker(robot, geometry=g).report(robot.q()) for g in ("hulls", "meshes")]
    except ManipkitError as exc:
        _one_line(exc)
        return
    for report in reports:  # no closest pair when the pair is in contact or none is checked
        assert report.min_distance is None or math.isfinite(report.min_distance.distance), report


# --- world files -------------------------------------------------------------------------------------

SCALAR = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-(10 ** 500), 10 ** 500),
                   st.sampled_from(["1e-3", "1E+2", ".5", "nan", "inf", "0x10", "1_000", "", "-0"]),
                   st.text(max_size=30), st.booleans(), st.none())
VALUE = st.recursive(SCALAR, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                     st.dictionaries(st.text(max_size=8), inner, max_size=3)),
                     max_leaves=20)
NAME = st.one_of(st.text(max_size=120), st.sampled_from(["floor", "base_link", "tool", "a\nb", "x" * 101]))
OBSTACLE = st.fixed_dictionaries({}, optional={"name": NAME, "box": VALUE, "sphere": VALUE, "cylinder": VALUE,
                                               "xyz": VALUE, "rpy": VALUE, "extra": VALUE})


@SETTINGS
@given(document=st.one_of(st.fixed_dictionaries({"obstacles": st.lists(OBSTACLE, max_size=5)}), VALUE))
def test_fuzzed_world_documents_are_refused_in_one_line_or_bounded(document):
    try:
        obstacles = world_obstacles(document)
    except ManipkitError as exc:
        _one_line(exc)
        return
    for name, _, T in obstacles:
        assert 0 < len(name) <= 100 and not CONTROL.search(name)
        assert np.isfinite(T).all() and np.abs(T[:3, 3]).max() <= 1e6


@SETTINGS
@given(yaml_text=st.one_of(
    st.integers(1, 60).map(lambda n: "obstacles: " + "[" * (n * 100) + "]" * (n * 100)),
    st.integers(2, 40).map(lambda n: "\n".join([f"a0: &a0 [{', '.join(['x'] * n)}]"]
                                                + [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * n)}]" for i in range(1, n)]
                                                + [f"obstacles: [{{name: b, sphere: *a{n - 1}}}]"])),
    st.text(max_size=300)))
def test_fuzzed_world_yaml_texts_end_in_one_line(tmp_path_factory, yaml_text):
    from manipkit.kinematics.world import read_world

    path = tmp_path_factory.mktemp("world") / "w.yaml"
    path.write_bytes(yaml_text.encode("utf-8", "replace"))
    try:
        read_world(path)
    except ManipkitError as exc:
        _one_line(exc)


# --- namespaced URDF ---------------------------------------------------------------------------------

DEFECTS = {"none": lambda t: t, "zero axis": lambda t: t.replace('<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>'),
           "reversed limits": lambda t: t.replace('lower="-2" upper="2"', 'lower="2" upper="-2"', 1),
           "dangling child": lambda t: t.replace('<child link="upper_arm"/>', '<child link="nowhere"/>'),
           "long offset": lambda t: t.replace('xyz="0 0 0.2"', 'xyz="0 0 1e7"')}
TAGS = ("link", "joint", "parent", "child", "axis", "limit", "origin", "inertial", "visual")


def _outcome(text: str, folder: Path, name: str):
    path = folder / name
    path.write_text(text)
    try:
        robot = manipkit.load(path)
    except ManipkitError as exc:
        _one_line(exc)
        return ("refused", re.sub(r"^\S+?\.urdf:\d+(:\d+)?: |\S+?\.urdf: ", "", str(exc)).replace(name, "ROBOT"))
    limits = {j: tuple(robot.limits[j]) if hasattr(robot, "limits") else None for j in robot.joint_names}
    return ("loaded", tuple(robot.joint_names), tuple(robot.frame_names), repr(limits),
            np.round(robot.transform(robot.root_link, "tool"), 12).tolist())


@SETTINGS
@given(defect=st.sampled_from(sorted(DEFECTS)), tags=st.sets(st.sampled_from(TAGS), min_size=1),
       every=st.booleans())
def test_fuzzed_namespaced_urdf_loads_as_its_plain_text_does(tmp_path_factory, defect, tags, every):
    folder = tmp_path_factory.mktemp("ns")
    plain = DEFECTS[defect](ARM)
    spaced = plain
    for tag in tags:
        pattern = re.compile(rf"<{tag}(?=[\s/>])")
        spaced = pattern.sub(f'<{tag} xmlns="urn:x"', spaced, count=0 if every else 1)
    assert _outcome(spaced, folder, "spaced.urdf") == _outcome(plain, folder, "plain.urdf")
