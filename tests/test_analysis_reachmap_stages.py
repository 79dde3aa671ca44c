"""The map's checks draw their poses where they say: :func:`stages.poses_in_bins`.

The false-positive bound draws one pose inside each of a set of voxel-bins
(uniform in the voxel, an orientation inside the bin). Judged independently
of the drawing code: each pose binned back by the map's own binning rule
(``keys_of``: the grid's cells and ``OrientationSet.bin_of``) is in the
voxel-bin it was drawn for, its rotation is a rotation, and the poses spread
over the voxel (a uniform offset in [-1/2, 1/2) has standard deviation
1/sqrt(12) = 0.289 voxel along each axis) and inside the bin (not only its centre).
"""

import math

import numpy as np
import pytest

from manipkit.analysis.reachmap.jobs import MapJob
from manipkit.analysis.reachmap.orientations import planar_orientations, spatial_orientations
from manipkit.analysis.reachmap.stages import keys_of, poses_in_bins

VOXEL = 0.1


def grid_job(orientations, planar: bool) -> MapJob:
    """A map job of a 9 x 9 x 9 grid (9 x 9 x 1 when planar): what the drawing and the binning read of it."""
    shape = (9, 9, 1) if planar else (9, 9, 9)
    axes = np.eye(3)
    origin = np.array([-0.4, -0.4, 0.0 if planar else -0.4])
    return MapJob(None, "tool", "base", np.arange(0), np.zeros(0), np.zeros(0), np.zeros(0), origin, axes, VOXEL, shape,
                  orientations, 0, 1, 0, "pose", 1e-6, 0, 0.0, False)


JOBS = {
    "spatial 20 directions, any roll": grid_job(spatial_orientations(20, 1), planar=False),
    "spatial 50 directions x 4 rolls": grid_job(spatial_orientations(50, 4), planar=False),
    "planar 36 turns": grid_job(planar_orientations(36, [0, 0, 1.0], [1.0, 0, 0], [0, 0, 1.0], [1.0, 0, 0]),
                                planar=True),
}


@pytest.mark.parametrize("name", JOBS)
def test_each_pose_is_drawn_inside_its_voxel_bin_and_spread_over_it(name):
    job = JOBS[name]
    rng = np.random.default_rng(7)
    keys = rng.integers(0, math.prod(job.shape) * job.orientations.size, 4000)
    T = poses_in_bins(job, keys, np.random.default_rng(11))
    assert T.shape == (len(keys), 4, 4)
    np.testing.assert_array_equal(T[:, 3], np.broadcast_to([0.0, 0.0, 0.0, 1.0], (len(keys), 4)))
    R = T[:, :3, :3]
    np.testing.assert_allclose(R @ R.transpose(0, 2, 1), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    np.testing.assert_array_equal(keys_of(job, T), keys)  # binned back: the voxel-bin each was drawn for
    # spread over the voxel: the offsets from the voxel centres, in voxels
    voxels = keys // job.orientations.size
    centres = job.origin + np.stack(np.unravel_index(voxels, job.shape), axis=-1) * VOXEL
    offset = (T[:, :3, 3] - centres) / VOXEL
    in_plane = 2 if job.orientations.kind == "planar" else 3
    assert np.all(np.abs(offset) <= 0.5)
    np.testing.assert_allclose(offset[:, :in_plane].std(axis=0), 1 / math.sqrt(12), atol=0.015)  # 4,000 draws
    if in_plane == 2:
        np.testing.assert_array_equal(offset[:, 2], 0.0)
    # and inside the bin, not only at its centre
    at_centre = np.all(np.isclose(R, job.orientations.rotations()[keys % job.orientations.size], atol=1e-9), axis=(1, 2))
    assert at_centre.mean() < 0.01, f"{at_centre.mean():.1%} of the orientations are the bin's centre"


def test_the_same_seed_draws_the_same_poses():
    job = JOBS["spatial 50 directions x 4 rolls"]
    keys = np.arange(0, 9**3 * 200, 997)
    np.testing.assert_array_equal(poses_in_bins(job, keys, np.random.default_rng(3)),
                                  poses_in_bins(job, keys, np.random.default_rng(3)))
    assert len(poses_in_bins(job, keys[:0], np.random.default_rng(3))) == 0
