import numpy as np

import mpmpp


def test_version_and_filter():
    g = mpmpp.TransferFunction([0.1003], [1.0, -0.9048], 17)
    assert mpmpp.__version__
    y = g.step(2000)
    assert np.allclose(y[:17], 0.0)
    assert abs(y[-1] - g.dc_gain()) < 1e-9
