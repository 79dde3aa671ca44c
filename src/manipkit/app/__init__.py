"""What users touch: the command line (:mod:`manipkit.app.cli`), the browser viewer and pose text.

The app presents; every number it shows comes from the layers below.
"""
