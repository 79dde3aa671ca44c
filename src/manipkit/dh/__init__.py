"""Denavit-Hartenberg tables: data and FK, files, printing, symbols, URDF, extraction and checks.

Standard DH (Spong, Corke): ``A_i = Rz(theta) Tz(d) Tx(a) Rx(alpha)``;
modified DH (Craig): ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``
(docs/architecture.md). The numeric and symbolic core needs numpy (and SymPy)
only; :func:`check_dh` and :func:`dh_from_urdf_chain` take a loaded
:class:`manipkit.Robot`.
"""

from manipkit.dh.table import *  # noqa: F401,F403
from manipkit.dh.table import __all__ as _table_all
from manipkit.dh.check import DHCheck, check_dh
from manipkit.dh.from_urdf import dh_from_urdf_chain

__all__ = [*_table_all, "DHCheck", "check_dh", "dh_from_urdf_chain"]
