"""The trained MLP that ships with dempath_recon (twin rig only).

``dempath reconstruct --method mlp`` without ``--model`` (and the reconstructor node with
``method: mlp`` and no ``model_file``) use ``data/mlp_twin_rig.pt``: the default
:class:`~dempath_recon.methods.mlp.MLPReconstructor` trained on the twin's calibration point set
(94,939 board corners seen through the twin rig, 0.2 px corner noise, seed 0) without the
paper's 4,149 held-out rows, weights stored as float16. A network maps pixels to 3D for one
camera pair in one place: it is valid for the twin rig (the demo's cameras) only. For other
cameras, train one on their calibration point set:
``dempath recon-train POINTS.npz --method mlp --out mlp.pt``.

The file is rebuilt by ``python -m dempath_twin.board.shipped_mlp`` (the twin makes the data),
which writes ``mlp_twin_rig.pt`` and ``mlp_twin_rig.json`` (provenance, training time, and the
accuracy of the file *as loaded* on the held-out rows). """

from __future__ import annotations

import logging
from pathlib import Path

from dempath_recon.methods.mlp import MLPReconstructor

logger = logging.getLogger(__name__)
DATA_DIR = Path(__file__).parents[1] / 'data'
SHIPPED_NAME = 'mlp_twin_rig'
SHIPPED_MODEL = DATA_DIR / f'{SHIPPED_NAME}.pt'
RIG_NOTE = ("valid for the twin rig (dempath_twin.rig.paper_rig, the demo's cameras) only; "
            'train your own with: dempath recon-train POINTS.npz --method mlp --out mlp.pt')


def load_shipped_mlp(device: str = 'cpu') -> MLPReconstructor:
    """The shipped network, ready to predict (float16 weights computed in float32)."""
    logger.info('method mlp: the shipped network %s (%s)', SHIPPED_MODEL.name, RIG_NOTE)
    return MLPReconstructor.load(SHIPPED_MODEL, device=device)
