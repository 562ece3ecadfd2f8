"""docs/worked_example.ipynb runs from top to bottom on the bundled data.

The notebook is the diagnosis' worked example through the typed entry point (a
``DiagnoseRequest`` of the bundled field twin against the shipped ``reduced_1ms`` library, no
simulation): executed here in a real Jupyter kernel (nbclient), it must name the hidden effect,
fit its strength within two standard deviations (its own last cell asserts it) and show the
statistics figure.
"""

from __future__ import annotations

from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / 'docs' / 'worked_example.ipynb'


def test_worked_example_notebook_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every cell runs without error; the verdict, the ranking and the figure come out."""
    monkeypatch.setenv('TMPDIR', str(tmp_path))  # the kernel's outputs go to the test's folder
    nb = nbformat.read(NOTEBOOK, as_version=4)
    assert all(not c.get('outputs') for c in nb.cells if c.cell_type == 'code'), \
        'the notebook is kept without outputs'
    NotebookClient(nb, timeout=300, kernel_name='python3',
                   resources={'metadata': {'path': str(ROOT / 'docs')}}).execute()
    text = '\n'.join(o.get('text', '') for c in nb.cells if c.cell_type == 'code'
                     for o in c.outputs if o.output_type == 'stream')
    assert 'verdict: effect_missing' in text, text
    assert 'hidden: cohesion' in text, text
    images = [o for c in nb.cells if c.cell_type == 'code' for o in c.outputs
              if 'image/png' in o.get('data', {})]
    assert len(images) == 1
