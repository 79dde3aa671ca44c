"""Reachability maps of any arm: build one, save and load it, ask it about poses, picture it, place a base with it.

(docs/site/internals/reach-maps.md.) The modules, each importing
only those listed before it:

- :mod:`~manipkit.analysis.reachmap.constants`: the reach codes, methods,
  format and every bound, with their checks.
- :mod:`~manipkit.analysis.reachmap.orientations`: the orientation bins
  (approach directions times rolls, or turns about a planar arm's axis).
- :mod:`~manipkit.analysis.reachmap.query`: what a map answers for a pose
  (:class:`QueryAnswer`, the support score, IK from the bin's certificate).
- :mod:`~manipkit.analysis.reachmap.payload`: the payload layer of a map
  (:class:`PayloadLayer`: best and worst capacity per voxel) and :func:`capacity_at`.
- :mod:`~manipkit.analysis.reachmap.store`: map folders (Zarr) written
  safely and read back validated.
- :mod:`~manipkit.analysis.reachmap.map`: the map, :class:`ReachMap`, and :func:`load`.
- :mod:`~manipkit.analysis.reachmap.blockstore`,
  :mod:`~manipkit.analysis.reachmap.blocks`: blocks of work run here or on a
  Dask cluster, merged in block order, kept for a resumed build.
- :mod:`~manipkit.analysis.reachmap.jobs`, :mod:`~manipkit.analysis.reachmap.stages`,
  :mod:`~manipkit.analysis.reachmap.resume`: one block of a build, the
  stages in order, and what a resumed build's saved blocks are keyed by.
- :mod:`~manipkit.analysis.reachmap.builder`: :func:`build`, the map of a chain.
- :mod:`~manipkit.analysis.reachmap.payloadmap`: :func:`payload_map`, the
  payload layer of a map, in blocks (here or on Dask), resumable.
- :mod:`~manipkit.analysis.reachmap.plot`: :func:`plot_reachmap`, slices as pictures.
- :mod:`~manipkit.analysis.reachmap.placement`: :func:`base_placement`,
  inverse reachability (where to put a mobile base).

``manipkit.reachmap`` is this package: ``manipkit.reachmap.build(robot)``,
``manipkit.reachmap.load(path)``.
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of(
        "manipkit.analysis.reachmap.constants",
        "DEFAULT_BLOCK", "DEFAULT_FP_CHECKS", "DEFAULT_HOLDOUT", "DEFAULT_SAMPLES", "DEFAULT_THRESHOLD", "FORMAT",
        "HOW_IK", "HOW_NONE", "HOW_SAMPLE", "LAYERS", "MAX_BINS", "MAX_BLOCK_SAMPLES", "MAX_FP_CHECKS", "MAX_GRID_BYTES",
        "MAX_IK_RESTARTS", "MAX_MAP_FILES", "MAX_SAMPLES", "MAX_SEED", "MAX_VOXEL", "METHODS", "MIN_VOXEL",
        "PARALLEL_TOL", "PLANAR_TILT_TOL", "check_threshold", "finite_array", "map_bytes",
    ),
    **homes_of("manipkit.analysis.reachmap.map", "ReachMap", "load"),
    **homes_of("manipkit.analysis.reachmap.builder", "build", "parse_orientations"),
    **homes_of("manipkit.analysis.reachmap.store", "writable_map_path"),
    **homes_of("manipkit.analysis.reachmap.query", "QueryAnswer"),
    **homes_of("manipkit.analysis.reachmap.orientations", "OrientationSet"),
    **homes_of("manipkit.analysis.reachmap.plot", "plot_reachmap"),
    **homes_of("manipkit.analysis.reachmap.payload", "PayloadLayer", "capacity_at"),
    **homes_of("manipkit.analysis.reachmap.payloadmap", "payload_map"),
    **homes_of(
        "manipkit.analysis.reachmap.placement",
        "BasePlacement", "base_placement", "confirm_placement", "placement_transforms", "plot_base_placement",
    ),
    **homes_of("manipkit.errors", "ReachMapError"),
})
