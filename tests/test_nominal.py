"""At the paper's physical parameters every plant and run path gives the numbers it gave
before the constants became parameters, bit for bit (`tests/nominal/record.py` recorded
them then; the fixture is `tests/nominal/reference.npz`). It runs on every host: a
difference fails, naming the platform the fixture was recorded on and this one (machine, C
library, the versions of Python, NumPy, numba and MuJoCo, the CPU features), and by how
much the arrays differ. Measured: the fixture, recorded on an AVX-512 Xeon, holds bit for
bit on an AMD EPYC without AVX-512."""

import numpy as np
import pytest

from nominal import record

with np.load(record.FIXTURE) as _archive:
    REFERENCE = {name: _archive[name] for name in _archive.files}
RECORDED_ON = str(REFERENCE.pop("platform"))


@pytest.fixture(scope="module")
def computed():
    return record.compute()


def test_the_same_numbers_are_computed(computed):
    assert sorted(computed) == sorted(REFERENCE)


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_every_array_is_bit_identical(computed, name):
    np.testing.assert_array_equal(
        computed[name], REFERENCE[name], strict=True,
        err_msg=f"{name}: recorded on {RECORDED_ON}; computed on {record.platform_of()}")
