"""A DAE visual as coloured triangles (manipkit.description.mesh_colours), against independent readers.

- The triangles: the file's, read here with ElementTree as the COLLADA schema
  says (node matrices, the VERTEX input's column of <p>, <unit meter>), in the
  file's order. (assimp, through coal, reads 136 of the UR5 base's 1,932
  triangles elsewhere: its second <triangles>, which pycollada, this reader and
  three.js, asked in a browser, all put on the base's side.)
- The colours: the ``<diffuse>`` colours of the materials the file's
  ``<triangles>`` name, read here with ElementTree from the COLLADA schema's
  chain (triangles material symbol -> instance_material target -> material
  -> instance_effect -> effect).
- What is drawn as the file instead (None): textures, translucency, another
  up axis, DOCTYPE/ENTITY declarations, files pycollada cannot read.
"""

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import manipkit
from manipkit.app.viewer import visual_model
from manipkit.description.mesh_colours import coloured_triangles

C = "{http://www.collada.org/2005/11/COLLADASchema}"


def dae_visuals(robot: str):
    return [g for g in visual_model(manipkit.load(robot)).geometryObjects if g.meshPath.lower().endswith(".dae")]


VISUALS = [(robot, g) for robot in ("panda", "ur5") for g in dae_visuals(robot)]
IDS = [f"{robot}-{g.name}" for robot, g in VISUALS]


def triangles_by_the_schema(path: str) -> np.ndarray:
    """(m, 3, 3) corners in metres, read here as the COLLADA 1.4 schema says (and three.js reads them): each
    <node>'s <matrix> times its parents', its <instance_geometry>'s <triangles> (stride = the largest input
    offset + 1, the VERTEX input's column), the <vertices>' POSITION array, times <unit meter>."""
    root = ET.parse(path).getroot()
    by_id = {e.get("id"): e for e in root.iter() if e.get("id")}
    unit = float(root.find(f"{C}asset/{C}unit").get("meter"))
    out = []

    def visit(node, T):
        matrix = node.find(f"{C}matrix")
        T = T @ (np.array(matrix.text.split(), float).reshape(4, 4) if matrix is not None else np.eye(4))
        for instance in node.findall(f"{C}instance_geometry"):
            for triangles in by_id[instance.get("url")[1:]].iter(f"{C}triangles"):
                inputs = triangles.findall(f"{C}input")
                stride = 1 + max(int(i.get("offset")) for i in inputs)
                vertex = next(i for i in inputs if i.get("semantic") == "VERTEX")
                source = by_id[vertex.get("source")[1:]].find(f"{C}input[@semantic='POSITION']").get("source")[1:]
                positions = np.array(by_id[source].find(f"{C}float_array").text.split(), float).reshape(-1, 3)
                index = np.array(triangles.find(f"{C}p").text.split(), int).reshape(-1, stride)[:, int(vertex.get("offset"))]
                corners = positions[index] @ T[:3, :3].T + T[:3, 3]
                out.append(corners.reshape(-1, 3, 3) * unit)
        for child in node.findall(f"{C}node"):
            visit(child, T)

    for scene in root.iter(f"{C}visual_scene"):
        for node in scene.findall(f"{C}node"):
            visit(node, np.eye(4))
    return np.concatenate(out)


@pytest.mark.parametrize("robot, geometry", VISUALS, ids=IDS)
def test_the_triangles_are_the_files(robot, geometry):
    mesh = coloured_triangles(geometry.meshPath, geometry.meshColor)
    assert mesh is not None, f"{geometry.meshPath} was not drawn as coloured triangles"
    assert mesh.vertices.shape == mesh.colours.shape and mesh.faces.max() < len(mesh.vertices)
    np.testing.assert_allclose(mesh.vertices[mesh.faces], triangles_by_the_schema(geometry.meshPath), rtol=0,
                               atol=1e-7)  # pycollada reads float32, as the browser draws


def diffuse_colours_named_by_triangles(path: str) -> set:
    """The RGB of each material a <triangles>/<polylist> of the file names, by the schema's references."""
    root = ET.parse(path).getroot()
    diffuse = {}
    for effect in root.iter(f"{C}effect"):
        colour = effect.find(f".//{C}diffuse/{C}color")
        diffuse[effect.get("id")] = tuple(round(float(v), 6) for v in colour.text.split()[:3])
    material_effect = {m.get("id"): m.find(f"{C}instance_effect").get("url").lstrip("#")
                       for m in root.iter(f"{C}material")}
    symbol_target = {i.get("symbol"): i.get("target").lstrip("#") for i in root.iter(f"{C}instance_material")}
    named = {p.get("material") for tag in ("triangles", "polylist", "polygons") for p in root.iter(f"{C}{tag}")}
    return {diffuse[material_effect[symbol_target[symbol]]] for symbol in named}


@pytest.mark.parametrize("robot, geometry", VISUALS, ids=IDS)
def test_each_vertex_has_the_diffuse_colour_of_its_material(robot, geometry):
    mesh = coloured_triangles(geometry.meshPath, geometry.meshColor)
    assert {tuple(row) for row in np.round(mesh.colours, 6)} == diffuse_colours_named_by_triangles(geometry.meshPath)


def test_the_ur5_shoulder_by_hand():
    """shoulder.dae (example-robot-data): 4,054 grey (0.1784), 136 near-black (0.064) and 9,302 blue triangles."""
    geometry = next(g for robot, g in VISUALS if robot == "ur5" and Path(g.meshPath).name == "shoulder.dae")
    mesh = coloured_triangles(geometry.meshPath)
    per_face = mesh.colours[mesh.faces[:, 0]]
    counts = {tuple(c): int(n) for c, n in zip(*np.unique(np.round(per_face, 4), axis=0, return_counts=True))}
    assert counts == {(0.1784, 0.1784, 0.1784): 4054, (0.064, 0.064, 0.064): 136, (0.3136, 0.4344, 0.512): 9302}


TRIANGLE = """<?xml version="1.0" encoding="utf-8"?>
{prolog}<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="centimetre" meter="0.01"/><up_axis>{up}</up_axis></asset>
  <library_images>{image}</library_images>
  <library_effects><effect id="e"><profile_COMMON><technique sid="common"><phong>
    <diffuse>{diffuse}</diffuse>{transparency}
  </phong></technique></profile_COMMON></effect></library_effects>
  <library_materials><material id="m"><instance_effect url="#e"/></material></library_materials>
  <library_geometries><geometry id="g"><mesh>
    <source id="p"><float_array id="pa" count="9">0 0 0 100 0 0 0 100 0</float_array>
      <technique_common><accessor source="#pa" count="3" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
      </accessor></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <triangles material="s" count="1"><input semantic="VERTEX" source="#v" offset="0"/><p>0 1 2</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="vs"><node id="n">
    <matrix>1 0 0 0.5 0 1 0 0 0 0 1 0 0 0 0 1</matrix>
    <instance_geometry url="#g"><bind_material><technique_common>
      <instance_material symbol="s" target="#m"/></technique_common></bind_material></instance_geometry>
  </node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#vs"/></scene>
</COLLADA>
"""
PLAIN = dict(prolog="", up="Z_UP", image="", diffuse='<color sid="diffuse">0.2 0.4 0.6 1</color>', transparency="")


def write_dae(tmp_path, **changes) -> Path:
    path = tmp_path / "mesh.dae"
    path.write_text(TRIANGLE.format(**{**PLAIN, **changes}))
    return path


def test_a_triangle_worked_by_hand(tmp_path):
    """Corners (0,0,0), (100,0,0), (0,100,0) cm, the node 0.5 cm along x: (0.005,0,0), (1.005,0,0), (0.005,1,0) m."""
    mesh = coloured_triangles(write_dae(tmp_path))
    np.testing.assert_allclose(mesh.vertices[mesh.faces[0]], [[0.005, 0, 0], [1.005, 0, 0], [0.005, 1.0, 0]], atol=1e-12)
    np.testing.assert_allclose(mesh.colours, [[0.2, 0.4, 0.6]] * 3)


@pytest.mark.parametrize("changes", [
    dict(up="Y_UP"),
    dict(diffuse='<texture texture="img" texcoord="uv"/>', image='<image id="img"><init_from>/etc/passwd</init_from></image>'),
    dict(diffuse='<color sid="diffuse">0.2 0.4 0.6 0.5</color>'),
    dict(transparency='<transparent opaque="A_ONE"><color>1 1 1 1</color></transparent>'
                      '<transparency><float>0.3</float></transparency>'),
    dict(transparency='<transparent opaque="RGB_ZERO"><color>0 0 0 1</color></transparent>'),
    dict(prolog='<!DOCTYPE c [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n'),
], ids=["y-up", "texture", "translucent-diffuse", "translucent-transparency", "rgb-zero", "doctype-entity"])
def test_what_would_be_drawn_otherwise_is_left_to_the_file(tmp_path, changes):
    assert coloured_triangles(write_dae(tmp_path, **changes)) is None


def test_a_colour_outside_0_1_is_clamped_as_the_browser_clamps_it(tmp_path):
    mesh = coloured_triangles(write_dae(tmp_path, diffuse='<color sid="diffuse">5 -1 0.5 1</color>'))
    np.testing.assert_array_equal(mesh.colours, [[1.0, 0.0, 0.5]] * 3)


def test_a_file_gone_since_the_load_is_left_to_the_file(tmp_path):
    assert coloured_triangles(tmp_path / "gone.dae") is None


@pytest.mark.parametrize("text", ["", "not xml at all", "<COLLADA/>", TRIANGLE.format(**PLAIN)[:700]],
                         ids=["empty", "text", "no-scene", "truncated"])
def test_a_file_pycollada_cannot_read_is_left_to_the_file(tmp_path, text):
    path = tmp_path / "mesh.dae"
    path.write_text(text)
    assert coloured_triangles(path) is None


@pytest.mark.parametrize("p, positions", [("0 1 -1", None), ("0 1 3", None), ("0 1 2", "0 0 0 1e400 0 0 0 1 0")],
                         ids=["negative-index", "index-past-the-end", "infinite-position"])
def test_indices_outside_the_positions_or_infinite_positions_are_left_to_the_file(tmp_path, p, positions):
    text = TRIANGLE.format(**PLAIN).replace("<p>0 1 2</p>", f"<p>{p}</p>")
    if positions:
        text = text.replace("0 0 0 100 0 0 0 100 0", positions)
    path = tmp_path / "mesh.dae"
    path.write_text(text)
    assert coloured_triangles(path) is None


@settings(max_examples=200, deadline=None, derandomize=True, database=None)
@given(cut=st.integers(0, len(TRIANGLE.format(**PLAIN))), junk=st.text(max_size=12), at=st.integers(0, 10_000))
def test_a_mangled_file_gives_coloured_triangles_or_none_and_never_raises(tmp_path_factory, cut, junk, at):
    text = TRIANGLE.format(**PLAIN)
    at %= len(text)
    path = tmp_path_factory.mktemp("mangled") / "mesh.dae"
    path.write_text((text[:at] + junk + text[at:])[:max(cut, at)], encoding="utf-8", errors="replace")
    mesh = coloured_triangles(path)
    if mesh is not None:
        assert np.isfinite(mesh.vertices).all() and mesh.faces.min() >= 0 and mesh.faces.max() < len(mesh.vertices)
        assert mesh.colours.shape == mesh.vertices.shape and ((0 <= mesh.colours) & (mesh.colours <= 1)).all()
