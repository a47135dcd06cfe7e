"""mpmpp: model-plant mismatch detection and model diagnosis from routine closed-loop data.

The numerics live in the C++/Eigen engine ``mpmpp._core``; this package orchestrates,
reads and writes the user's files, plots and talks to the user.

Names load on first use (PEP 562), so ``mpmpp --help`` does not pay for the engine,
pandas and matplotlib.
"""
from __future__ import annotations

import importlib
import sys
import types

# public name -> module that defines it (relative to this package)
_EXPORTS = {
    "__version__": "._core", "TransferFunction": "._core",
    "QpResult": "._core", "QpSolver": "._core", "solve_qp": "._core",
    "Model": ".io", "load_data": ".io", "load_model": ".io", "save_data": ".io", "save_model": ".io",
    "OneClassSVM": ".svm", "cross_validate_outlier_fraction": ".svm", "resample": ".svm",
    "simulate": ".simulate",
    "compare": ".compare",
    "diagnose": ".diagnose",
    "update": ".update",
    "DetectionResult": ".detect", "Detector": ".detect", "DetectorConfig": ".detect", "detect": ".detect",
    "StreamingDetector": ".stream",
}
# submodules reachable as attributes after ``import mpmpp``
_SUBMODULES = {"identify", "scenarios"}

__all__ = sorted(set(_EXPORTS) | _SUBMODULES)


def __getattr__(name: str):
    if name in _SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    if name not in _EXPORTS:
        raise AttributeError(f"module 'mpmpp' has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name], __name__), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__():
    return __all__


class _Package(types.ModuleType):
    """``simulate``, ``compare``, ``diagnose``, ``update`` and ``detect`` name both a module and
    its main function; the function wins, as ``from .simulate import simulate`` made it. The
    import system binds a submodule on its package once the submodule is loaded (for any
    ``import mpmpp.simulate``, also from inside the package): the function is bound instead."""

    def __setattr__(self, name, value):
        if isinstance(value, types.ModuleType) and _EXPORTS.get(name) == f".{name}":
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
