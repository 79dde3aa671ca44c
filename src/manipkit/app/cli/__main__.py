"""``python -m manipkit.app.cli COMMAND ...``: the same as the ``manipkit`` command."""

import sys

from manipkit.app.cli import main

sys.exit(main())
