"""mpmpp: model-plant mismatch detection and model diagnosis from routine closed-loop data.

The numerics live in the C++/Eigen engine ``mpmpp._core``; this package orchestrates,
reads and writes the user's files, plots and talks to the user.
"""
from ._core import TransferFunction, __version__
from .simulate import simulate

__all__ = ["TransferFunction", "__version__", "simulate"]
