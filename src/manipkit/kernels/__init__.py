"""The bottom layer of compiled code: compiling numba kernels (:mod:`manipkit.kernels.compile`) and the one
compiled program of a chain (:mod:`manipkit.kernels.fk`, :mod:`manipkit.kernels.program`: steps, batched FK,
Jacobian, IK packing, row tables, thread count) and the rows of a batch in blocks on threads
(:mod:`manipkit.kernels.blocks`). numpy and numba only (numba on the first compile); no
Pinocchio, no import of the layers above.
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of("manipkit.kernels.blocks", "run_blocks"),
    **homes_of("manipkit.kernels.compile", "KERNEL_MARKERS", "KernelCacheWarning", "compile_kernel", "kernel_closure",
               "lazy_kernel", "sources_digest"),
    **homes_of("manipkit.kernels.fk", "MAX_THREADS", "ChainFK", "ChainStep", "chain_fk", "pose_rows", "pose_rows_kernel",
               "row_tables", "snap_placement", "thread_count", "z_to_axis"),
    **homes_of("manipkit.kernels.program", "ChainProgram", "IKProgram", "JacobianProgram", "pack_chain"),
})
