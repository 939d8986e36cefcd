"""Hypothesis profiles (registered by conftest.py).

``ci`` (the default, used by ``make test``): derandomized, so every run of
the suite draws the same examples (a submission cannot land or fail by
luck), no example database (a failure found earlier on this machine does
not change what runs), no deadline (the machine may be shared).

``fuzz`` (``make fuzz``, or ``HYPOTHESIS_PROFILE=fuzz``): fresh random
examples on every run and ``FUZZ_FACTOR`` times as many of them (env
``STIFFKIT_FUZZ_FACTOR``, default 5); failures are saved to the example
database (.hypothesis/) and printed with their reproduction blob.

A test asks for its number of examples with :func:`examples` (its count
under ``ci``), so that ``fuzz`` scales every property test alike.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

PROFILE = os.environ.get("HYPOTHESIS_PROFILE", "ci")
FUZZ_FACTOR = int(os.environ.get("STIFFKIT_FUZZ_FACTOR", "5"))
_QUIET = [HealthCheck.function_scoped_fixture, HealthCheck.too_slow]

settings.register_profile("ci", derandomize=True, database=None, deadline=None, print_blob=True)
settings.register_profile(
    "fuzz",
    derandomize=False,
    deadline=None,
    print_blob=True,
    max_examples=100 * FUZZ_FACTOR,
    suppress_health_check=_QUIET,
)


def load() -> None:
    if PROFILE not in ("ci", "fuzz"):
        raise ValueError(f"HYPOTHESIS_PROFILE={PROFILE!r}: choose ci or fuzz")
    settings.load_profile(PROFILE)


def examples(n: int) -> int:
    """``n`` examples under ``ci``, ``FUZZ_FACTOR`` x n under ``fuzz``."""
    return n * FUZZ_FACTOR if PROFILE == "fuzz" else n
