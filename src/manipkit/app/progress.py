"""Progress of long work, drawn on stderr: the one way the app shows it (tqdm).

The library never draws: long functions (``analysis.dexterity.global_conditioning_index``,
``analysis.reachmap.build``) take ``progress``, a callable
``progress(stage, done, total)`` called as work finishes (``stage`` names the
work, ``done`` of ``total`` its units). :func:`progress_bar` gives the
callable that draws one bar per stage, or None (no bars) when disabled; the
command line enables it when stderr is a terminal (``--progress yes|no|auto``
where a command has it). Bars are transient: the answer stays alone on stdout
and nothing is left on stderr.

Examples
--------
>>> with progress_bar(False) as progress:
...     progress is None
True
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

__all__ = ["ProgressCallback", "progress_bar"]

ProgressCallback = Callable[[str, int, int], None]


@contextmanager
def progress_bar(enabled: bool | None = None) -> Iterator[ProgressCallback | None]:
    """A ``progress(stage, done, total)`` callable drawing a tqdm bar per stage on stderr; None when disabled.

    ``enabled=None`` means: when stderr is a terminal. Every bar is closed
    when the block ends, also on an error or Ctrl-C.
    """
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled:
        yield None
        return
    from tqdm import tqdm

    bars: dict[str, tqdm] = {}

    def progress(stage: str, done: int, total: int) -> None:
        bar = bars.get(stage)
        if bar is None:
            bar = bars[stage] = tqdm(total=total, desc=stage, file=sys.stderr, leave=False, dynamic_ncols=True)
        bar.update(done - bar.n)

    try:
        yield progress
    finally:
        for bar in bars.values():
            bar.close()
