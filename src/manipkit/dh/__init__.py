"""Denavit-Hartenberg tables: data and FK, files, printing, symbols, URDF, extraction and checks.

Standard DH (Spong, Corke): ``A_i = Rz(theta) Tz(d) Tx(a) Rx(alpha)``;
modified DH (Craig): ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``
(docs/architecture.md).

- :mod:`~manipkit.dh.table`: :class:`DHRow`, :class:`DHTable`,
  :func:`dh_link_transform`, :func:`dh_fk` (the numeric core).
- :mod:`~manipkit.dh.files`: :func:`load_dh`, :func:`save_dh`,
  :func:`dh_from_yaml`, :func:`yaml_from_dh` (the table file format).
- :mod:`~manipkit.dh.text`: :func:`format_dh_table`, the boxed printout (``str(table)``);
  :func:`html_dh_table`, :func:`latex_dh_table` (Jupyter's views).
- :mod:`~manipkit.dh.symbolic`: :func:`dh_symbols`, :func:`dh_fk_symbolic`,
  :func:`shorthand`, :func:`format_symbolic` (forward kinematics in SymPy).
- :mod:`~manipkit.dh.symbolic_jacobian`: :func:`dh_jacobian_symbolic`, the frames and the
  geometric Jacobian in SymPy; :mod:`~manipkit.dh.symbolic_statics`: :func:`dh_gravity_symbolic`,
  the gravity torques g(q) with point masses.
- :mod:`~manipkit.dh.to_urdf`: :func:`urdf_from_dh`, a URDF whose chain equals the table's
  (:func:`save_urdf` writes it).
- :mod:`~manipkit.dh.from_urdf`: :func:`dh_from_urdf_chain`, the table of a robot's chain.
- :mod:`~manipkit.dh.check`: :func:`check_dh`, agreement with a robot and a diagnosis
  (with a corrected table).
- :mod:`~manipkit.dh.diagnosis`: :class:`DHDiagnosis` and its parts, the diagnosis as
  data (worded by :mod:`manipkit.app.dh_text`).
- :mod:`~manipkit.dh.entries`: rows as elementary transforms; :func:`reverse_joint`.

The numeric and symbolic core needs numpy (and SymPy) only; :func:`check_dh`
and :func:`dh_from_urdf_chain` take a loaded :class:`manipkit.Robot`. SymPy
and PyYAML are imported inside the functions that need them.
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of("manipkit.dh.table", "CONVENTIONS", "JOINT_TYPES", "DHRow", "DHTable", "dh_fk", "dh_link_transform"),
    **homes_of("manipkit.dh.check", "DHCheck", "check_dh"),
    **homes_of("manipkit.dh.diagnosis", "DHDiagnosis"),
    **homes_of("manipkit.dh.files", "bundled_tables", "dh_from_yaml", "load_dh", "save_dh", "yaml_from_dh"),
    **homes_of(
        "manipkit.dh.symbolic",
        "dh_fk_symbolic", "dh_length_symbols", "dh_symbols", "format_symbolic", "shorthand",
    ),
    **homes_of("manipkit.dh.symbolic_jacobian", "dh_frames_symbolic", "dh_jacobian_symbolic"),
    **homes_of("manipkit.dh.symbolic_statics", "dh_gravity_symbolic"),
    **homes_of("manipkit.dh.from_urdf", "dh_from_urdf_chain"),
    **homes_of("manipkit.dh.text", "format_dh_table", "html_dh_table", "latex_dh_table"),
    **homes_of("manipkit.dh.entries", "reverse_joint"),
    **homes_of("manipkit.dh.to_urdf", "save_urdf", "urdf_from_dh"),
})
