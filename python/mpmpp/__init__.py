"""mpmpp: model-plant mismatch detection and model diagnosis from routine closed-loop data.

The numerics live in the C++/Eigen engine ``mpmpp._core``; this package orchestrates,
reads and writes the user's files, plots and talks to the user.
"""
from ._core import __version__
from ._core import TransferFunction
from ._core import QpResult, QpSolver, solve_qp
from .io import Model, load_data, load_model, save_data, save_model
from . import identify
from .svm import OneClassSVM, cross_validate_outlier_fraction, resample
from .simulate import simulate
from . import scenarios
from .compare import compare
from .diagnose import diagnose
from .update import update
from .detect import DetectionResult, Detector, DetectorConfig, detect
from .stream import StreamingDetector
