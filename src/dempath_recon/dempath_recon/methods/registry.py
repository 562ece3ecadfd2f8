# ruff: noqa: N803  (X for pixels, as in scikit-learn)
"""One interface over every reconstruction method, so that nodes, CLIs and compare can swap them.

A reconstructor has ``fit(X (n, 4) px, y (n, 3) m, calibration=...) -> self`` and
``predict(pixels (n, 4) px) -> (n, 3) m``. Methods by name:

- ``dlt``: linear triangulation with depth re-weighting (no training; needs a calibration, or
  resects the cameras from the point set);
- ``dlt_refined``: the same plus Gauss-Newton refinement of the pixel reprojection error;
- ``dlt_residual``: triangulation plus a small network learning its residual;
- ``mlp``: the paper's 2048-1024-512 network (a trained one for the twin rig ships with the
  package, ``dempath_recon.methods.shipped``).

The two learned methods need torch, an optional dependency (the extra ``mlp``,
``requirements-mlp.txt``); it is imported only when one of them is asked for, and its absence is
one clear :class:`ReconstructionError` line (:func:`learned_class`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from dempath_recon.errors import ModelFileError, ReconstructionError
from dempath_recon.methods.triangulate import DLTTriangulator

FloatArray = NDArray[np.float64]
METHODS = ('dlt', 'dlt_refined', 'dlt_residual', 'mlp')


class Reconstructor(Protocol):
    """The shared estimator surface."""

    name: str

    def fit(self, X: FloatArray, y: FloatArray, **kwargs: Any) -> Any:
        """Learn from calibration pixels (n, 4) px and points (n, 3) m."""

    def predict(self, pixels: FloatArray) -> FloatArray:
        """Pixels (n, 4) px -> points (n, 3) m."""


TORCH_HINT = ("pip install 'torch' (dempath_recon's extra 'mlp'; in this repository: "
              'requirements-mlp.txt, installed by make setup)')


def learned_class(method: str) -> Any:
    """The estimator class of a learned method (``mlp``, ``dlt_residual``), importing torch.

    Raises:
        ReconstructionError: torch, an optional dependency, is not installed.
    """
    try:
        if method == 'mlp':
            from dempath_recon.methods.mlp import MLPReconstructor

            return MLPReconstructor
        from dempath_recon.methods.residual import ResidualReconstructor
    except ImportError as err:
        if (err.name or '').split('.')[0] != 'torch':
            raise
        msg = f'method: {method!r} needs torch, which is not installed: {TORCH_HINT}'
        raise ReconstructionError(msg) from err
    return ResidualReconstructor


def make_reconstructor(method: str, **params: Any) -> Any:
    """A new, unfitted reconstructor for ``method`` with hyperparameters ``params``.

    Raises:
        ReconstructionError: unknown method name.
    """
    if method == 'dlt':
        return DLTTriangulator(refine=False)
    if method == 'dlt_refined':
        return DLTTriangulator(refine=True)
    if method in ('dlt_residual', 'mlp'):
        return learned_class(method)(**params)
    msg = f'method: unknown {method!r}; known: {", ".join(METHODS)}'
    raise ReconstructionError(msg)


def load_calibration(path: str | Path) -> Any:
    """Read a dempath stereo calibration YAML (``dempath_calib.camera.StereoCalibration``).

    Raises:
        ModelFileError: missing or malformed file (one clear line naming the file).
    """
    from dempath_calib.camera import StereoCalibration
    from dempath_calib.errors import CalibrationFileError

    try:
        return StereoCalibration.load(path)
    except CalibrationFileError as err:
        raise ModelFileError(' '.join(str(err).split())) from err  # YAML errors span lines


def load_reconstructor(method: str, calibration_file: str = '', model_file: str = '',
                       device: str = 'auto') -> Any:
    """A ready-to-predict reconstructor from files, as the node and the CLI need it.

    Args:
        method: one of ``METHODS``.
        calibration_file: stereo YAML; required by ``dlt`` and ``dlt_refined``.
        model_file: torch file written by ``save``; required by ``dlt_residual``; for ``mlp``
            empty means the shipped network, valid for the twin rig only.
        device: torch device for the learned methods.

    Raises:
        ReconstructionError: unknown method or missing file argument.
        ModelFileError: a file is missing or corrupt.
    """
    if method in ('dlt', 'dlt_refined'):
        if not calibration_file:
            msg = f'calibration_file: method {method!r} needs a stereo calibration YAML'
            raise ReconstructionError(msg)
        return make_reconstructor(method).fit(calibration=load_calibration(calibration_file))
    if method == 'mlp' and not model_file:
        learned_class(method)  # torch is there, or one clear line
        from dempath_recon.methods.shipped import load_shipped_mlp

        return load_shipped_mlp(device)
    if method in ('mlp', 'dlt_residual'):
        if not model_file:
            msg = f'model_file: method {method!r} needs a trained model file'
            raise ReconstructionError(msg)
        return learned_class(method).load(model_file, device=device)
    msg = f'method: unknown {method!r}; known: {", ".join(METHODS)}'
    raise ReconstructionError(msg)
