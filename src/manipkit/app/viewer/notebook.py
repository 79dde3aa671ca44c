"""The view inside Jupyter: the same state and scene, with ipywidgets sliders, frame pickers and a readout.

ipywidgets (and IPython) are imported when a view is built; see
docs/architecture.md ("app").
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from manipkit.app.viewer.collision_state import collision_view
from manipkit.app.viewer.scene import MeshcatScene, visual_model
from manipkit.app.viewer.state import DEFAULT_FRAMES, Overlay, ViewerState
from manipkit.errors import ManipkitError, ViewerError

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["NotebookView", "notebook_view"]


class NotebookView:
    """A view inside a notebook: ipywidgets sliders, frame pickers, a readout and the meshcat scene.

    Build it with :func:`notebook_view`; display it as the last expression of
    a cell. ``sliders`` (joint name -> FloatSlider), ``frame_a``/``frame_b``
    (Dropdown), ``reset_button``, ``readout`` (HTML), the manipulability
    overlay's ``ellipsoid`` (Checkbox), ``ellipsoid_kind`` and
    ``ellipsoid_axes`` (Dropdown) and ``ellipsoid_readout`` (HTML), the
    collisions' ``collision_readout`` (HTML; empty when nothing is checked), and
    ``widget`` are the ipywidgets; ``state`` and ``scene`` are the shared layers.
    """

    def __init__(self, state: ViewerState, scene: MeshcatScene, visual, *, height: int = 420):
        import ipywidgets as w

        self.state, self.scene, self.visual = state, scene, visual
        self._syncing = False
        self.sliders = {
            spec.name: w.FloatSlider(
                value=spec.value, min=spec.lower, max=spec.upper, step=spec.step, description=spec.name,
                continuous_update=True, readout_format=".4f", style={"description_width": "initial"},
                layout=w.Layout(width="100%"),
            )
            for spec in state.sliders()
        }
        choices = list(state.frame_choices())
        self.frame_a = w.Dropdown(options=choices, value=state.frames[0], description="A")
        self.frame_b = w.Dropdown(options=choices, value=state.frames[1], description="B")
        self.reset_button = w.Button(description="reset")
        overlay = state.overlay
        self.ellipsoid = w.Checkbox(value=overlay.shown, description="manipulability ellipsoid", indent=False)
        self.ellipsoid_kind = w.Dropdown(options=["velocity", "force"], value=overlay.kind, layout=w.Layout(width="auto"))
        self.ellipsoid_axes = w.Dropdown(options=[("translation", "trans"), ("rotation", "rot")], value=overlay.axes,
                                         layout=w.Layout(width="auto"))
        self.ellipsoid_readout = w.HTML()
        self.collision_readout = w.HTML()
        self.readout = w.HTML()
        self.error = w.HTML()
        self.scene_widget = w.HTML(
            f'<iframe src="{scene.url}" style="width:100%;height:{height}px;border:0"></iframe>',
            layout=w.Layout(width="60%"),
        )
        for name, slider in self.sliders.items():
            slider.observe(lambda change, name=name: self._on_joint(name, change["new"]), names="value")
        self.frame_a.observe(lambda change: self._on_frames(), names="value")
        self.frame_b.observe(lambda change: self._on_frames(), names="value")
        self.reset_button.on_click(lambda button: self._on_reset())
        for widget in (self.ellipsoid, self.ellipsoid_kind, self.ellipsoid_axes):
            widget.observe(lambda change: self._on_overlay(), names="value")
        controls = w.VBox([*self.sliders.values(), w.HBox([self.frame_a, self.frame_b]), self.reset_button,
                           w.HBox([self.ellipsoid, self.ellipsoid_kind, self.ellipsoid_axes]), self.error,
                           self.collision_readout, self.readout, self.ellipsoid_readout], layout=w.Layout(width="40%"))
        self.widget = w.HBox([controls, self.scene_widget])
        self._refresh()

    def _on_joint(self, name: str, value: float) -> None:
        if not self._syncing:
            self.state.set_joint(name, value)
            self._refresh()

    def _on_frames(self) -> None:
        if not self._syncing:
            try:
                self.state.set_frames(self.frame_a.value, self.frame_b.value)
            except ManipkitError as exc:  # the message names frames: user text, escaped for the HTML widget
                import html

                self.error.value = f"<span style='color:#b00'>{html.escape(str(exc))}</span>"
                return
            self._refresh()

    def _on_overlay(self) -> None:
        if not self._syncing:
            self.state.set_overlay(shown=self.ellipsoid.value, kind=self.ellipsoid_kind.value,
                                   axes=self.ellipsoid_axes.value)
            self._refresh()

    def _on_reset(self) -> None:
        self.state.reset()
        self._refresh()

    def _refresh(self) -> None:
        """Draw the scene and show the readout; put the sliders where the state says."""
        import html

        self.scene.draw(self.state.scene_placements(self.visual), self.state.scene_visibility(),
                        self.state.collision_tints(self.visual))
        self._syncing = True
        try:
            for spec in self.state.sliders():
                self.sliders[spec.name].value = spec.value
        finally:
            self._syncing = False
        snapshot = self.state.snapshot()
        self.error.value = ""
        self.readout.value = f"<pre>{html.escape(snapshot['readout_text'])}</pre>"
        text = snapshot["ellipsoid_text"]
        self.ellipsoid_readout.value = f"<pre>{html.escape(text)}</pre>" if text else ""
        text = snapshot["collisions_text"]
        colour = "#a00" if snapshot["collisions"] and snapshot["collisions"].get("in_collision") else "inherit"
        self.collision_readout.value = f"<pre style='color:{colour}'>{html.escape(text)}</pre>" if text else ""

    def close(self) -> None:
        """Stop the meshcat server."""
        self.scene.close()

    def _ipython_display_(self):
        from IPython.display import display

        display(self.widget)


def notebook_view(robot: Robot, frames: tuple[str, str] = DEFAULT_FRAMES, q=None, *,
                  ellipsoid: bool | str = False, ellipsoid_axes: str = "trans", collisions: str = "none",
                  floor: float | None = 0.0, srdf=None, geometry: str = "hulls") -> NotebookView:
    """The viewer inline in Jupyter: meshcat scene plus ipywidgets sliders and a live T_A_B readout.

    ``ellipsoid``: start with the manipulability ellipsoid shown (``True`` or
    ``"velocity"``, or ``"force"``); ``ellipsoid_axes``: ``"trans"`` or ``"rot"``.
    ``collisions``: ``"self"``, ``"floor"``, ``"self,floor"`` or ``"none"`` (the
    default), with ``floor`` (m, root frame), ``srdf`` and ``geometry`` as
    :func:`~manipkit.app.viewer.collision_state.collision_view` takes them: links
    in contact are drawn red and the readout names the pairs and the closest pair.

    Raises
    ------
    ManipkitError
        If ipywidgets is not installed (``pip install ipywidgets``).
    """
    try:
        import ipywidgets  # noqa: F401
    except ImportError:
        raise ViewerError("the notebook viewer needs ipywidgets: pip install ipywidgets") from None
    overlay = Overlay(bool(ellipsoid), ellipsoid if isinstance(ellipsoid, str) else "velocity", ellipsoid_axes)
    checks = collision_view(robot, collisions, floor=floor, geometry=geometry, srdf=srdf)
    state = ViewerState(robot, frames=frames, q=q, overlay=overlay, collisions=checks)
    visual = visual_model(robot)
    scene = MeshcatScene(visual, robot.model, bounds=state.bounds(visual), base=state.base_origin(),
                         floor_height=None if checks is None else checks.floor)
    try:
        return NotebookView(state, scene, visual)
    except BaseException:
        scene.close()
        raise
