"""What users touch: the command line (:mod:`manipkit.app.cli`), the browser viewer (:mod:`manipkit.app.viewer`) and pose text (:mod:`manipkit.app.pose`).

The app presents; every number it shows comes from the layers below
(docs/architecture.md).
"""

__all__: list[str] = []
