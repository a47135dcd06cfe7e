"""signals.filtered_columns against scipy.signal.lfilter run per segment and column."""
import numpy as np
from scipy.signal import lfilter

from mpmpp._core import TransferFunction
from mpmpp.signals import Signals, filtered_columns


def _signals(n: int, segments: list[tuple[int, int]]) -> Signals:
    return Signals(time_s=np.arange(n, dtype=float), inputs=[], outputs=[], extras=[], u=np.zeros((n, 0)),
                   y=np.zeros((n, 0)), z=np.zeros((n, 0)), operating_point={}, segments=segments)


def _reference(g: TransferFunction, x: np.ndarray) -> np.ndarray:
    """g on x from rest: the rational part by lfilter, then the dead time as zeros shifted in."""
    y = lfilter(np.asarray(g.num), np.asarray(g.den), x)
    return np.r_[np.zeros(g.delay), y[: len(x) - g.delay]]


def test_every_column_through_every_filter_per_segment_nan_outside():
    rng = np.random.default_rng(3)
    n, segments = 400, [(5, 180), (230, 400)]
    x = rng.standard_normal((n, 3))
    filters = [TransferFunction([0.4], [1.0, -0.6], 1), TransferFunction([1.0, -0.5], [1.0, -0.9, 0.2], 3)]
    got = filtered_columns(_signals(n, segments), filters, x)
    assert got.shape == (n, 6)
    outside = np.ones(n, bool)
    for a, b in segments:
        outside[a:b] = False
        for c in range(3):
            for f, g in enumerate(filters):
                np.testing.assert_allclose(got[a:b, 2 * c + f], _reference(g, x[a:b, c]), rtol=1e-12, atol=1e-12)
    assert np.isnan(got[outside]).all()


def test_column_major_input_gives_the_same_result():
    rng = np.random.default_rng(4)
    x = rng.standard_normal((300, 4))
    sig, g = _signals(300, [(0, 300)]), [TransferFunction([0.2], [1.0, -0.8], 0)]
    np.testing.assert_array_equal(filtered_columns(sig, g, x), filtered_columns(sig, g, np.asfortranarray(x)))
