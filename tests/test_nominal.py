"""At the paper's physical parameters every plant and run path gives the numbers it gave
before the constants became parameters, bit for bit (`tests/nominal/record.py` recorded
them then; the fixture is `tests/nominal/reference.npz`)."""

import numpy as np
import pytest

from nominal import record


@pytest.fixture(scope="module")
def computed():
    return record.compute()


@pytest.fixture(scope="module")
def reference():
    with np.load(record.FIXTURE) as archive:
        return {name: archive[name] for name in archive.files}


def test_the_same_numbers_are_computed(computed, reference):
    assert sorted(computed) == sorted(reference)


@pytest.mark.parametrize("name", sorted(np.load(record.FIXTURE).files))
def test_every_array_is_bit_identical(computed, reference, name):
    np.testing.assert_array_equal(computed[name], reference[name], strict=True)
