"""mpmpp: model-plant mismatch detection and model diagnosis from routine closed-loop data.

The numerics live in the C++/Eigen engine ``mpmpp._core``; this package orchestrates,
reads and writes the user's files, plots and talks to the user.
"""
from ._core import TransferFunction, __version__
from .io import Model, load_data, load_model, save_data, save_model

__all__ = ["TransferFunction", "__version__", "Model", "load_model", "save_model", "load_data", "save_data"]
