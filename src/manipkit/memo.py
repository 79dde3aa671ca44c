"""Tables a module keeps for the process, bounded: the oldest entry goes first.

What is made once and asked for again (a chain's family and solver, a textbook
arm's plan, a xacro expansion, an SRDF parse) is kept in a module-level dict;
:func:`keep` is the one rule by which such a table stays bounded. Whether an
entry may still be used (the same chain object, the same file bytes) is the
keeping module's rule, not this one's.
"""

from __future__ import annotations

__all__ = ["keep"]


def keep(table: dict, key, value, *, limit: int):
    """Put ``value`` in ``table`` under ``key`` as its newest entry, drop the oldest past ``limit``; return ``value``.

    Safe beside other threads doing the same without a lock: an entry another thread dropped meanwhile is not
    dropped again, and a table another thread changes during the drop is left as it is (at worst a few entries
    over ``limit`` until the next call). A key that cannot be hashed raises TypeError, as the dict does.

    >>> table = {}
    >>> [keep(table, k, k * k, limit=2) for k in (1, 2, 3)]
    [1, 4, 9]
    >>> table
    {2: 4, 3: 9}
    >>> keep(table, 2, 5, limit=2), list(table)  # kept again: now the newest
    (5, [3, 2])
    """
    table.pop(key, None)
    table[key] = value
    while len(table) > limit:
        try:
            table.pop(next(iter(table)), None)
        except (StopIteration, RuntimeError):  # emptied or changed by another thread meanwhile
            break
    return value
