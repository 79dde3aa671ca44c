"""The one rule that names the closed-form branches of a 6R arm (or a 7R arm at an arm angle or with a joint
locked): :func:`branch_names`, used by the single call (:func:`manipkit.ik.chain_ik.chain_ik`, its compiled and
its general path) and by the batch (:meth:`manipkit.ik.result.IKBatch.branch_labels` of
:func:`manipkit.ik.chain_ik.chain_ik_many`), so both give a branch the same name.

A name is three words (:func:`branch_words`):

- UR, OPW and spherical-wrist families: ``"front|back, elbow up|down, no flip|wrist flip"`` (shoulder: the wrist
  centre on the side of axis 1 where it is at ``q0``, or the other; elbow: above or below the shoulder-wrist line,
  "above" along axis 1 turned to point up the base z; wrist: the angle of the middle wrist joint, wrapped to
  (-pi, pi], >= 0 or < 0), with ``" (read tip to base)"`` for a family solved on the reversed chain;
- a 7R SRS arm at its arm angle: ``"elbow +|-, shoulder +|-, no flip|wrist flip"`` (the signs of joints 4 and 2
  and of joint 6, wrapped to (-pi, pi]).

These words do not always tell the branches of one answer apart: on a 7R arm with a joint locked (the Panda or
iiwa14 with ``lock=``) the "elbow" point of the locked 6R arm lies on axis 2, so every branch counts as "elbow up"
and two distinct solutions share the words. Then (:func:`numbered`) each row sharing its words with another gets
``" #1"``, ``" #2"``, ... in the solver's slot order (shoulder choice, elbow choice, wrist choice), so the names of
one answer are distinct and a branch's number is the same in the single call and in the batch.
"""

from __future__ import annotations

import numpy as np

from manipkit.closed_form.arms import ELBOW_TIE, rotation_matrix
from manipkit.closed_form.subproblems import rotate
from manipkit.ik.families import OPW, SRS, UR
from manipkit.spatial.rotations import wrap_angle

__all__ = ["REVERSED", "SRS_WORDS", "WORDS", "branch_names", "branch_words", "label_order", "numbered"]

#: The words of the compiled paths by code (4 back + 2 elbow down + wrist flip), as :func:`branch_words` gives them.
WORDS = tuple(f"{'back' if c & 4 else 'front'}, {'elbow down' if c & 2 else 'elbow up'}, "
              f"{'wrist flip' if c & 1 else 'no flip'}" for c in range(8))
#: What a family solved on the reversed chain adds to its words.
REVERSED = " (read tip to base)"
#: A 7R SRS arm's words by code (4 elbow - + 2 shoulder - + wrist flip).
SRS_WORDS = tuple(f"elbow {'-' if c & 4 else '+'}, shoulder {'-' if c & 2 else '+'}, "
                  f"{'wrist flip' if c & 1 else 'no flip'}" for c in range(8))


def numbered(words) -> tuple[str, ...]:
    """``words`` (one per row, in slot order) with ``" #k"`` (k = 1, 2, ... in that order) after each one that
    another row shares: distinct names for one answer's rows.

    >>> numbered(["front, elbow up", "back, elbow up", "front, elbow up"])
    ('front, elbow up #1', 'back, elbow up', 'front, elbow up #2')
    """
    words = list(words)
    if len(set(words)) == len(words):
        return tuple(words)
    seen: dict[str, int] = {}
    names = []
    for word in words:
        if words.count(word) == 1:
            names.append(word)
            continue
        seen[word] = seen.get(word, 0) + 1
        names.append(f"{word} #{seen[word]}")
    return tuple(names)


def label_order(label: str) -> tuple[bool, bool, bool]:
    """The sort key of a name: front, elbow up, no flip first (a stable sort keeps numbered rows in slot order)."""
    return ("back" in label, "elbow down" in label, "wrist flip" in label)


def branch_words(arm, g: np.ndarray, theta: np.ndarray, compiled: bool = False) -> list[str]:
    """Shoulder, elbow and wrist of each branch, as words (the module's rule, before :func:`numbered`).

    ``arm``: the family's :class:`~manipkit.ik.ideal_arm.IdealArm`; ``g`` (4, 4): the target as the solver takes
    it (``T M^-1``, inverted for a reversed family); ``theta`` (k, n): the branches' angles (rad) in the solve
    direction, any 2 pi alias. ``compiled``: the UR and OPW words by the compiled kernel (the same words).
    """
    h, p = arm.h, arm.p
    kind = arm.family.kind
    theta = wrap_angle(np.asarray(theta, dtype=float))  # (-pi, pi]: the same words for every 2 pi alias of a row
    signs = theta >= 0.0
    if kind == SRS:  # the arm angle is given: the elbow's sign, the shoulder's and the wrist's split name a branch
        return [f"elbow {'+' if s[3] else '-'}, shoulder {'+' if s[1] else '-'}, "
                f"{'no flip' if s[5] else 'wrist flip'}" for s in signs]
    c = arm.points["wrist"]
    s = arm.points.get("shoulder", p[1])
    reference, up = arm.label_axes
    if compiled and kind in (UR, OPW):
        from manipkit.closed_form.arms_kernel import branch_labels

        bits = branch_labels(kind, h, p, c, s, reference, up, g, theta).tolist()
        return [f"{'front' if f else 'back'}, {'elbow up' if a else 'elbow down'}, {'no flip' if t else 'wrist flip'}"
                for f, a, t in bits]
    w = g[:3, :3] @ c + g[:3, 3]
    w1 = p[0] + rotate(h[0], -theta[:, 0], w - p[0])  # (k, 3)
    front = (w1 - p[0]) @ reference >= 0.0
    E1 = rotation_matrix(h[0], theta[:, 0])  # (k, 3, 3)

    def turned(x):
        return p[0] + np.einsum("kij,kj->ki", E1, np.broadcast_to(x - p[0], (len(theta), 3)))

    shoulder_point = turned(s)
    elbow = turned(p[1] + rotate(h[1], theta[:, 1], p[2] - p[1]))
    wrist = np.broadcast_to(w, elbow.shape)
    if kind == UR:  # the point on axis 4, moved
        E3p4 = p[2] + rotate(h[2], theta[:, 2], p[3] - p[2])
        wrist = turned(p[1] + rotate(h[1], theta[:, 1], E3p4 - p[1]))
    normal = E1 @ h[1]  # the arm's plane is normal to axis 2: compare within it

    def in_plane(x):
        return x - np.sum(x * normal, axis=-1, keepdims=True) * normal

    line, offset = in_plane(wrist - shoulder_point), in_plane(elbow - shoulder_point)
    length = np.sum(line * line, axis=-1, keepdims=True)
    offset = offset - np.where(length > 0.0, np.sum(offset * line, axis=-1, keepdims=True) / np.where(length > 0, length, 1.0), 0.0) * line
    above = offset @ up >= -ELBOW_TIE * np.sqrt(length[:, 0])  # on the line: up, as the compiled labels say
    return [f"{'front' if f else 'back'}, {'elbow up' if a else 'elbow down'}, {'no flip' if t else 'wrist flip'}"
            for f, a, t in zip(front, above, signs[:, 4])]


def branch_names(arm, g: np.ndarray, theta: np.ndarray, compiled: bool = False) -> tuple[str, ...]:
    """The names of one answer's branches (rows of ``theta`` in slot order, as :func:`branch_words` takes them):
    the words, ``" (read tip to base)"`` for a reversed family, then :func:`numbered`."""
    words = branch_words(arm, g, theta, compiled)
    if arm.family.reversed:
        words = [w + REVERSED for w in words]
    return numbered(words)
