"""The allowed-collision matrix: which link pairs a collision check may skip, by MoveIt's Setup Assistant's rules.

Rules, applied in this order to every pair of links with collision geometry
(the reasons are MoveIt's, so the SRDF reads back in MoveIt):

- ``Adjacent``: joined by a joint (links without geometry passed through),
  :func:`manipkit.kinematics.collisions.adjacent_links`;
- ``Default``: in contact at the robot's default configuration (``robot.q()``);
- ``Always``: in contact in at least ``always`` (95 %) of ``samples``
  configurations drawn uniformly inside the joint limits (``robot.sample_q``);
- ``Never``: in contact in none of them.

Every other pair stays enabled (checked). The samples are checked in blocks
by :meth:`manipkit.kinematics.collisions.CollisionChecker.contact_counts`:
Pinocchio's C++ threads (``workers``, default every core) find the samples
with any contact, then those alone are checked pair by pair. Each query
starts afresh, so the counts, and the matrix, do not depend on ``workers``.
After filtering,
:func:`allowed_collision_matrix` checks that no enabled pair is in contact at
the default configuration (:attr:`CollisionMatrix.default_contacts`, empty
when it holds). The matrix belongs to the geometry it was sampled with
(``hulls`` or ``meshes``); the SRDF says which.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import OptionError

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["REASONS", "CollisionMatrix", "MatrixComparison", "allowed_collision_matrix", "compare_matrix", "srdf_text"]

#: The reasons a pair is disabled, in the order the rules run (MoveIt's names).
REASONS = ("Adjacent", "Default", "Always", "Never")
#: Most samples one matrix takes.
MAX_SAMPLES = 10_000_000
#: Fewest samples checked per call of the threads (two threads' worth: see
#: :data:`manipkit.kinematics.collisions.MIN_ROWS_PER_THREAD`); the progress is reported after each block.
BLOCK = 2000


@dataclass(frozen=True)
class CollisionMatrix:
    """An allowed-collision matrix (:func:`allowed_collision_matrix`).

    Attributes
    ----------
    robot : str
    geometry : str
        ``"hulls"`` or ``"meshes"``: the geometry the pairs were checked with.
    samples, seed : int
        How many random configurations were checked, from which seed.
    always : float
        The fraction of samples in contact from which a pair is ``Always``.
    disabled : Mapping[(str, str), str]
        Link pair (sorted names) -> reason (one of :data:`REASONS`).
    enabled : tuple of (str, str)
        The pairs left to check.
    contacts : Mapping[(str, str), int]
        In how many samples each pair sampled was in contact.
    default_contacts : tuple of (str, str)
        Enabled pairs in contact at the default configuration (the check after filtering: empty when it holds).
    """

    robot: str
    geometry: str
    samples: int
    seed: int
    always: float
    disabled: Mapping
    enabled: tuple
    contacts: Mapping
    default_contacts: tuple

    def counts(self) -> dict[str, int]:
        """How many pairs each reason disabled, in :data:`REASONS` order."""
        return {reason: sum(1 for r in self.disabled.values() if r == reason) for reason in REASONS}


def allowed_collision_matrix(robot: Robot, *, samples: int = 10_000, seed: int = 0, geometry: str = "hulls",
                             always: float = 0.95, workers: int | None = None,
                             progress: Callable[[str, int, int], None] | None = None) -> CollisionMatrix:
    """The allowed-collision matrix of ``robot`` by the Setup Assistant's rules (module docstring).

    Parameters
    ----------
    robot : Robot
    samples : int, keyword-only
        Random configurations checked (default 10,000, as MoveIt's Setup Assistant).
    seed : int, keyword-only
        Seed of the samples (``robot.sample_q(samples, seed=seed)``): the same seed gives the same matrix.
    geometry : str, keyword-only
        ``"hulls"`` (default) or ``"meshes"``.
    always : float, keyword-only
        Fraction of samples in contact from which a pair is disabled as ``Always`` (default 0.95).
    workers : int, keyword-only, optional
        Threads checking the samples (default: every core); the matrix is the same for any number.
    progress : callable, optional
        ``progress(stage, done, total)``, called as samples are checked.

    Raises
    ------
    OptionError
        ``samples`` not a whole number from 1 to :data:`MAX_SAMPLES`, ``always`` not in (0, 1].
    CollisionError
        The robot has no collision geometry (or its meshes are missing); ``workers`` not a whole number from 1 to
        :data:`manipkit.kinematics.collisions.MAX_THREADS`.
    """
    from manipkit.kinematics.collision_geometry import collision_geometry
    from manipkit.kinematics.collisions import CollisionChecker, thread_count

    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 1 <= samples <= MAX_SAMPLES:
        raise OptionError(f"samples {samples}: give a whole number from 1 to {MAX_SAMPLES:,}")
    if not (isinstance(always, (int, float)) and 0 < always <= 1):
        raise OptionError(f"always {always}: give a fraction of samples in (0, 1], such as 0.95")
    workers = thread_count(workers)
    shapes = collision_geometry(robot, geometry)
    names = shapes.link_names
    everything = [tuple(sorted((a, b))) for i, a in enumerate(names) for b in names[i + 1:]]
    disabled = {pair: "Adjacent" for pair in everything if pair in shapes.adjacent}
    rest = [pair for pair in everything if pair not in disabled]
    default_q = robot.q()
    if rest:
        for pair in CollisionChecker(robot, geometry=geometry, pairs=rest).pairs_in_contact(default_q):
            disabled[pair] = "Default"
    rest = [pair for pair in rest if pair not in disabled]
    counts = dict.fromkeys(rest, 0)
    if rest:
        checker = CollisionChecker(robot, geometry=geometry, pairs=rest)
        Q = robot.sample_q(int(samples), seed=seed)
        block = max(BLOCK, -(-len(Q) // 20))  # progress every 5 % of a large run, every block of a small one
        for start in range(0, len(Q), block):
            for pair, count in checker.contact_counts(Q[start:start + block], workers=workers).items():
                counts[pair] += count
            if progress is not None:
                progress("sampling configurations", min(start + block, len(Q)), len(Q))
    for pair, count in counts.items():
        if count >= always * samples:
            disabled[pair] = "Always"
        elif count == 0:
            disabled[pair] = "Never"
    enabled = tuple(pair for pair in everything if pair not in disabled)
    default_contacts = ()
    if enabled:
        default_contacts = tuple(sorted(CollisionChecker(robot, geometry=geometry, pairs=enabled)
                                        .pairs_in_contact(default_q)))
    return CollisionMatrix(robot.name, geometry, int(samples), seed, float(always),
                           MappingProxyType(dict(sorted(disabled.items()))), enabled,
                           MappingProxyType(counts), default_contacts)


@dataclass(frozen=True)
class MatrixComparison:
    """A matrix compared pair by pair with an SRDF's ``<disable_collisions>`` (:func:`compare_matrix`).

    Attributes
    ----------
    srdf : str
        The SRDF compared with.
    total : int
        Pairs compared: every pair of links with collision geometry.
    agree : int
        Pairs both disable, or both check.
    same_reason : int
        Of ``agree``, the disabled pairs with the same reason in both.
    differences : tuple of (str, str, str, str, str)
        (link1, link2, ours, theirs, why) of each pair one disables and the other checks; ours and theirs are
        a reason of :data:`REASONS` (theirs may be ``User``) or ``"checked"``.
    """

    srdf: str
    total: int
    agree: int
    same_reason: int
    differences: tuple


def compare_matrix(matrix: CollisionMatrix, disabled: Mapping, srdf: str) -> MatrixComparison:
    """``matrix`` against ``disabled`` (an SRDF's pairs: (link1, link2) sorted -> reason, read from ``srdf``).

    The reason given for a difference is the count behind our rule: a pair
    we check was in contact in some samples (so it is not ``Never``); a pair
    we disable as ``Never`` was in contact in none of ours, and one disabled
    as ``Default`` is in contact at the home configuration.
    """
    pairs = list(matrix.disabled) + list(matrix.enabled)
    agree = same = 0
    differences = []
    for pair in sorted(pairs):
        ours, theirs = matrix.disabled.get(pair, "checked"), disabled.get(pair, "checked")
        if (ours == "checked") == (theirs == "checked"):
            agree += 1
            same += ours == theirs and ours != "checked"
            continue
        count = matrix.contacts.get(pair)
        if ours == "checked":
            why = f"in contact in {count} of {matrix.samples} samples with {matrix.geometry}, so not Never"
        elif ours == "Never":
            why = f"in contact in none of {matrix.samples} samples with {matrix.geometry}"
        elif ours == "Default":
            why = f"in contact at the home configuration with {matrix.geometry}"
        elif ours == "Always":
            why = f"in contact in {count} of {matrix.samples} samples with {matrix.geometry}"
        else:
            why = "joined by a joint (links without geometry passed through)"
        differences.append((*pair, ours, theirs, why))
    return MatrixComparison(srdf, len(pairs), agree, same, tuple(differences))


def srdf_text(matrix: CollisionMatrix) -> str:
    """The matrix as a MoveIt-compatible SRDF: ``<disable_collisions link1= link2= reason=/>`` per disabled pair."""
    from xml.sax.saxutils import escape, quoteattr

    percent = f"{100 * matrix.always:g}"
    lines = [
        '<?xml version="1.0" encoding="utf-8"?>',
        f"<!-- Allowed-collision matrix of {escape(matrix.robot).replace('--', '- -')}, made by manipkit acm with "
        f"{matrix.geometry} geometry: {matrix.samples} samples (seed {matrix.seed}); Always at >= {percent} % of "
        "samples. Pairs not listed are checked. -->",
        f"<robot name={quoteattr(matrix.robot)}>",
    ]
    for (a, b), reason in matrix.disabled.items():
        lines.append(f"    <disable_collisions link1={quoteattr(a)} link2={quoteattr(b)} reason={quoteattr(reason)}/>")
    lines.append("</robot>")
    return "\n".join(lines) + "\n"
