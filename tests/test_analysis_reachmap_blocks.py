"""analysis.reachmap.blocks: a LocalCluster's workers are forked with what every block needs already imported."""

import sys

from manipkit.analysis.reachmap.blocks import FORK_SERVER_PRELOAD, BlockRunner


def _imported(names):
    return sorted(name for name in names if name in sys.modules)


def test_local_workers_start_with_the_preloaded_modules_before_any_block():
    # Nothing was sent to the workers yet: a module they hold came from the fork server they were forked from.
    # Without the preload none of manipkit's is there (a bare Dask worker imports no manipkit module).
    with BlockRunner(2, None) as runner:
        held = runner.client.run(_imported, list(FORK_SERVER_PRELOAD))
    assert len(held) == 2
    assert all(names == sorted(FORK_SERVER_PRELOAD) for names in held.values()), held
