"""Test-suite settings.

Hypothesis runs derandomized by default so that `make test` (and CI) give the
same result on every run; `HYPOTHESIS_PROFILE=explore` draws fresh random
examples each run (use it when hunting for bugs, as `make fuzz` does).
"""

from hypothesis import settings

settings.register_profile("ci", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
import os

settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
