"""Task paths: can a chain follow a tool path, on which IK branches, how fast, and if not, where and why
(docs/architecture.md, "paths": imports the IK layer and everything below it except dh and closed_form).

Poses are ``T_base_tip`` stacks ``(N, 4, 4)`` in metres; joint paths are ``(N, n)`` in the chain's own joint
order (radians or metres); times in seconds.
"""

from __future__ import annotations

from manipkit.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {})
