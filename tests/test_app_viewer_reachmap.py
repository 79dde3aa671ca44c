"""manipkit.app.viewer.reachmap_scene: a reachability map drawn in meshcat, checked by decoding the static page.

Independent sources: the map's own reachable voxels and values (what must be
drawn), matplotlib's viridis colour map, and meshcat's drawing commands read
back out of the standalone HTML (base64 msgpack, decoded here with umsgpack).
"""

import base64
import re

import numpy as np
import pytest
import umsgpack
from matplotlib import colormaps

from manipkit.analysis.reachmap import build
from manipkit.app.viewer.reachmap_scene import voxel_bands, write_reachmap_html
from manipkit.errors import OutputError, ReachMapError


@pytest.fixture(scope="module")
def map_3r(planar_3r):
    return build(planar_3r, voxel=0.5, orientations=8, samples=6000, block_samples=2048)


def meshcat_commands(html: str) -> list[dict]:
    blobs = re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
    return [umsgpack.unpackb(base64.b64decode(blob)) for blob in blobs]


def cloud(command: dict) -> tuple[np.ndarray, np.ndarray]:
    """(positions (N, 3), colours (N, 3)) of a meshcat point cloud command (float32, column-major 3 x N)."""
    attributes = command["object"]["geometries"][0]["data"]["attributes"]
    position = np.frombuffer(attributes["position"]["array"].data, dtype=np.float32).reshape(-1, 3)
    colour = np.frombuffer(attributes["color"]["array"].data, dtype=np.float32).reshape(-1, 3)
    return position, colour


def test_bands_split_the_reachable_voxels_by_value(map_3r):
    bands = voxel_bands(map_3r, "index")
    centres = np.concatenate([b.centres for b in bands])
    values = np.concatenate([b.values for b in bands])
    assert len(centres) == int(map_3r.reachable.sum()) and values.min() > 0.0
    np.testing.assert_array_equal(np.sort(values), np.sort(map_3r.index[map_3r.reachable]))
    for band in bands:
        low, high = (float(v) for v in band.path.rsplit("/", 1)[1].split("-"))
        assert band.path.startswith("reachmap/index/") and (band.values >= low).all() and (band.values <= high).all()
        np.testing.assert_allclose(band.colours, colormaps["viridis"](band.values)[:, :3])
    top = voxel_bands(map_3r, "manipulability")[-1]
    assert top.values.max() == np.nanmax(map_3r.manipulability)
    np.testing.assert_allclose(top.colours[np.argmax(top.values)], colormaps["viridis"](1.0)[:3])


def test_static_page_holds_one_point_per_reachable_voxel_at_its_centre(map_3r, planar_3r, tmp_path):
    path = write_reachmap_html(map_3r, tmp_path / "map.html", robot=planar_3r)
    commands = meshcat_commands(path.read_text())
    clouds = {c["path"]: cloud(c) for c in commands if c["type"] == "set_object" and "/reachmap/" in c["path"]}
    index_paths = [p for p in clouds if p.startswith("/meshcat/reachmap/index/")]
    positions = np.concatenate([clouds[p][0] for p in index_paths])
    colours = np.concatenate([clouds[p][1] for p in index_paths])
    centres = map_3r.centers()[map_3r.reachable]
    assert len(positions) == len(centres) == int(map_3r.reachable.sum())
    order_drawn, order_map = np.lexsort(positions.T), np.lexsort(centres.T)
    np.testing.assert_allclose(positions[order_drawn], centres[order_map], atol=1e-6)
    expected = colormaps["viridis"](map_3r.index[map_3r.reachable])[:, :3]
    np.testing.assert_allclose(colours[order_drawn], expected[order_map], atol=1e-6)
    # the dexterous voxels (index 1) are the top band, drawn in viridis' yellow
    dexterous = clouds["/meshcat/reachmap/index/0.8-1"][1]
    assert (np.abs(dexterous - colormaps["viridis"](1.0)[:3]).max(axis=1) < 1e-6).sum() == int(map_3r.dexterous.sum())
    visible = {c["path"]: c["value"] for c in commands if c["type"] == "set_property" and c["property"] == "visible"}
    assert visible["/meshcat/reachmap/index"] is True and visible["/meshcat/reachmap/manipulability"] is False
    assert any(p.startswith("/meshcat/reachmap/manipulability/") for p in clouds)
    sizes = {c["object"]["materials"][0]["size"] for c in commands if c["path"] in clouds}
    assert sizes == {0.5}  # each point a voxel across
    assert any(c["type"] == "set_object" and "/pinocchio/visuals/" in c["path"] for c in commands)  # the robot


def test_refusals(map_3r, planar_2r, planar_3r, tmp_path):
    with pytest.raises(ReachMapError, match="the map is of 'planar_3r', not of 'planar_2r'"):
        write_reachmap_html(map_3r, tmp_path / "m.html", robot=planar_2r)
    with pytest.raises(ReachMapError, match="unknown layer 'speed'"):
        voxel_bands(map_3r, "speed")
    with pytest.raises(OutputError, match="cannot write"):
        write_reachmap_html(map_3r, tmp_path / "missing" / "m.html", robot=planar_3r)
