"""CMAC tile coding (SPEC.md, "Baseline"): binary, one tile per tiling, offset tilings."""

import numpy as np
import pytest

from lwrl.agent.cmac import CMAC

CAR = CMAC(low=(-1.2, -0.07), high=(0.5, 0.07))


def active(cmac, state):
    return np.flatnonzero(cmac.features(state))


def test_one_active_tile_per_tiling():
    """5 tilings of 9 x 9 tiles: 405 features, exactly 5 equal to 1 for any state."""
    states = np.random.default_rng(0).uniform(-3, 3, size=(500, 2))
    features = CAR.features(states)
    assert features.shape == (500, 405) and CAR.num_features == 405
    assert set(np.unique(features)) == {0.0, 1.0}
    assert np.all(features.sum(axis=1) == 5)
    tiling_of_active = np.nonzero(features)[1] // 81
    assert np.all(np.sort(tiling_of_active.reshape(500, 5), axis=1) == np.arange(5))


def test_tiles_by_hand():
    """Normalised state (0.5, 0.25), 8 intervals, 5 tilings: tiling t's tile in a dimension
    is floor(s * 8 + t / 5): x -> 4, 4, 4, 4, 4 and v -> 2, 2, 2, 2, 2 (4.0 + 0.8 < 5),
    so feature t * 81 + 4 * 9 + 2 = 38 + 81 t. At (0.55, 0.25): 4.4 + t/5 crosses 5 from
    t = 3, so x -> 4, 4, 4, 5, 5."""
    two_d = CMAC(low=(0.0, 0.0), high=(1.0, 1.0))
    assert active(two_d, [0.5, 0.25]).tolist() == [38 + 81 * t for t in range(5)]
    x_tiles = [4, 4, 4, 5, 5]
    assert active(two_d, [0.55, 0.25]).tolist() == [81 * t + 9 * x + 2 for t, x in enumerate(x_tiles)]


def test_out_of_range_states_use_edge_tiles():
    two_d = CMAC(low=(0.0, 0.0), high=(1.0, 1.0))
    assert active(two_d, [-5.0, 7.0]).tolist() == [81 * t + 0 * 9 + 8 for t in range(5)]


def test_nearby_states_share_tiles_and_far_ones_do_not():
    """Generalisation: states a small step apart share most tiles."""
    near = len(set(active(CAR, [-0.5, 0.0])) & set(active(CAR, [-0.49, 0.001])))
    far = len(set(active(CAR, [-0.5, 0.0])) & set(active(CAR, [0.3, 0.05])))
    assert near >= 3 and far == 0


def test_alpha_normalisation():
    assert CAR.alpha_scale == 1.0
    assert CMAC((0.0,), (1.0,), tilings=10, normalise_alpha=True).alpha_scale == 0.1


@pytest.mark.parametrize("kwargs, message", [
    (dict(low=(0.0,), high=(0.0,)), "low must be finite and below"),
    (dict(low=(0.0, 1.0), high=(1.0,)), "same length"),
    (dict(low=(0.0,), high=(1.0,), intervals=0), "intervals must be an integer >= 1"),
    (dict(low=(0.0,), high=(1.0,), tilings=2.5), "tilings must be an integer >= 1"),
])
def test_bad_input(kwargs, message):
    with pytest.raises(ValueError, match=message):
        CMAC(**kwargs)
