"""Browser view of a robot: meshcat scene, joint sliders and a live T_A_B readout.

Four layers, each usable on its own (docs/architecture.md, "app"):

- :mod:`.state`: :class:`ViewerState` holds the joint values, the frames
  A, B and the manipulability overlay (:class:`Overlay`) and answers the
  slider specs, the readout (the JSON of ``tf-between A B --format json``),
  the ellipsoid readout and the scene placements. No meshcat, no browser.
- :mod:`.collision_state`: :func:`collision_view`, what a view checks for
  collisions (self, the floor) or why it cannot; the state asks it for the
  report at each pose, the scene tints the links in contact.
- :mod:`.scene`: :func:`visual_model` (the robot's visual geometry) and
  :class:`MeshcatScene`, a thin adapter that starts a meshcat server and
  draws the placements it is given, with a triad at A and at B; its
  visualizer (:mod:`.coloured_meshes`) sends a DAE visual as coloured triangles.
- :mod:`.server`: :class:`ViewerServer` serves the control page
  (``page.html``) and wires it to a state and a scene, answering only that
  page's own requests (its Host, its Origin, the session token); :func:`open_view`
  starts a view, :func:`write_static` writes a standalone HTML snapshot.
- :mod:`.notebook`: :func:`notebook_view`, the same view in Jupyter with ipywidgets.

Conventions: metres and radians; ``T_a_b`` is the pose of frame b expressed
in frame a; the scene's world frame is the robot's root link. Pinocchio,
meshcat, ``pinocchio.visualize`` and ipywidgets are imported inside the
functions that need them, so importing this package stays cheap.
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of(
        "manipkit.app.viewer.state",
        "DEFAULT_FRAMES", "ELLIPSOID_PATH", "TRIAD_PATHS", "VISUALS_ROOT", "Overlay", "SliderSpec", "ViewerState",
    ),
    **homes_of("manipkit.app.viewer.collision_state", "CollisionView", "collision_view"),
    **homes_of("manipkit.app.viewer.scene", "TRIAD_DOTS", "MeshcatScene", "visual_model"),
    **homes_of("manipkit.app.viewer.server", "DEFAULT_PORT", "ViewerServer", "open_view", "write_static"),
    **homes_of("manipkit.app.viewer.notebook", "NotebookView", "notebook_view"),
})
