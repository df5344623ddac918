"""At the paper's physical parameters every plant and run path gives the numbers it gave
before the constants became parameters, bit for bit (`tests/nominal/record.py` recorded
them then; the fixture is `tests/nominal/reference.npz`). The numbers are the recording
platform's: on another (other library versions, other CPU features), the test says so and
skips."""

import numpy as np
import pytest

from nominal import record

with np.load(record.FIXTURE) as _archive:
    REFERENCE = {name: _archive[name] for name in _archive.files}
RECORDED_ON = str(REFERENCE.pop("platform"))


@pytest.fixture(scope="module")
def computed():
    if record.platform_of() != RECORDED_ON:
        pytest.skip(f"the fixture's numbers are those of {RECORDED_ON}; this is "
                    f"{record.platform_of()} (record them here from the same code: "
                    f"python tests/nominal/record.py)")
    return record.compute()


def test_the_same_numbers_are_computed(computed):
    assert sorted(computed) == sorted(REFERENCE)


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_every_array_is_bit_identical(computed, name):
    np.testing.assert_array_equal(computed[name], REFERENCE[name], strict=True)
