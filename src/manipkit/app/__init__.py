"""What users touch: the command line (:mod:`manipkit.app.cli`), the browser viewer (:mod:`manipkit.app.viewer`), pose text (:mod:`manipkit.app.pose`) and the Jacobian report's words (:mod:`manipkit.app.jacobian_text`, shared by ``manipkit jacobian`` and the viewer).

The app presents; every number it shows comes from the layers below
(docs/architecture.md).
"""

__all__: list[str] = []
