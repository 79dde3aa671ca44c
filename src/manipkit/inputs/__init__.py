"""Reading files a user names, safely: regular files only, bounded in size, one-line errors.

- :mod:`manipkit.inputs.files`: :func:`check_input_file` and :func:`read_text`,
  which every file read on a user's behalf goes through (descriptions, xacro
  includes, DH tables, ``--q-file`` tables, YAML loaded from xacro), the
  size limits, and :func:`file_digest`, which tells a memo of what was read
  from a file whether the file still holds the same.
- :mod:`manipkit.inputs.matrices`: :func:`read_matrix`, a hand-written 4x4
  (or 3x3) in the formats people paste.
- :mod:`manipkit.inputs.poses`: :func:`read_targets`, target poses for base placement.
- :mod:`manipkit.inputs.yamls`: :func:`load_yaml`, YAML bounded in depth and size (aliases counted).

The input layer sits on :mod:`manipkit.spatial` (a pose read from a file is
checked as a transform) and below every layer that reads files
(docs/architecture.md, "Layers"). The names below load their module on first use.
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of(
        "manipkit.inputs.files",
        "MAX_DESCRIPTION_BYTES", "MAX_MATRIX_BYTES", "MAX_TABLE_BYTES", "check_input_file", "file_digest", "read_text",
    ),
    **homes_of("manipkit.inputs.matrices", "read_matrix"),
    **homes_of("manipkit.inputs.poses", "read_targets"),
    **homes_of("manipkit.inputs.yamls", "load_yaml"),
})
