import numpy as np
import pytest
from _profiles import load

# hypothesis: derandomized "ci" profile unless HYPOTHESIS_PROFILE=fuzz (tests/_profiles.py)
load()


@pytest.fixture
def rng():
    return np.random.default_rng(20090601)
