"""What users touch: the command line (:mod:`manipkit.app.cli`), the browser viewer (:mod:`manipkit.app.viewer`), pose text (:mod:`manipkit.app.pose`), the Jacobian report's words (:mod:`manipkit.app.jacobian_text`, shared by ``manipkit jacobian`` and the viewer) and the ``dh check`` diagnosis in words (:mod:`manipkit.app.dh_text`, for the CLI and the notebooks).

The app presents; every number it shows comes from the layers below
(docs/architecture.md).
"""

from __future__ import annotations

from manipkit.exports import lazy_exports

# The app exports no names: its entry points are manipkit.app.cli (main, tf_between_main) and manipkit.app.viewer.
__all__, __getattr__, __dir__ = lazy_exports(__name__, {})
