"""``dempath demo`` interrupted with Ctrl-C during the graph: what is written stays readable.

The demo runs as a user runs it (the console script, in its own process) on the bundled
rendered recording and the tiny scene. Once the graph is recording, SIGINT is sent: the demo
says in one line where it stopped, exits with 130, the MCAP bag is finalised (the ``mcap``
reader reads its summary and every message; rosbags reads its metadata) and ``timing.json``
lists the stage that finished.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from dempath.bagio import open_bag

# the demo in its own process up to the graph: long on a loaded machine
pytestmark = pytest.mark.timeout(1500)
ROOT = Path(__file__).resolve().parents[1]
RENDER = ROOT / 'bags' / 'field_render_reduced_1ms'
WAIT_S = 900.0  # generous: calibration and start-up on a loaded machine

def _default_sigint() -> None:
    """In the child: SIGINT back to its default (a shell running the suite in the background
    starts it ignored, and a process that inherits that ignores Ctrl-C)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)



def wait_for(condition: object, timeout_s: float) -> bool:
    """Poll ``condition()`` every 0.2 s until it holds or ``timeout_s`` passes."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():  # type: ignore[operator]
            return True
        time.sleep(0.2)
    return bool(condition())  # type: ignore[operator]


def test_ctrl_c_during_the_graph_keeps_a_readable_bag(tmp_path: Path) -> None:
    """SIGINT while the graph records: exit 130, one line, the MCAP bag readable."""
    out = tmp_path / 'out'
    dempath = Path(sys.executable).with_name('dempath')
    proc = subprocess.Popen([str(dempath), 'demo', '--field-bag', str(RENDER), '--scene', 'tiny',
                             '--rate', '0.1', '--out', str(out)], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env={**os.environ},
                            preexec_fn=_default_sigint)
    bag = out / f'run_{RENDER.name}'
    try:
        recording = wait_for(lambda: proc.poll() is None and any(
            p.stat().st_size > 0 for p in bag.glob('*.mcap')), WAIT_S)
        assert recording, f'the graph never started recording (exit {proc.poll()})'
        # let some messages in: a flushed chunk with a camera image (hundreds of kB) grows the
        # file well past its header, schemas and channels (tens of kB); playback at a tenth
        (mcap,) = bag.glob('*.mcap')
        header = mcap.stat().st_size
        assert wait_for(lambda: proc.poll() is None
                        and mcap.stat().st_size > header + 100_000, WAIT_S), \
            f'nothing recorded past the header (exit {proc.poll()})'
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, (proc.returncode, stdout[-2000:], stderr[-2000:])
    lines = [ln for ln in stderr.splitlines() if ln.startswith('interrupted during')]
    assert len(lines) == 1 and 'graph' in lines[0], stderr[-2000:]
    assert 'Traceback' not in stderr, stderr[-3000:]
    (mcap_file,) = bag.glob('*.mcap')
    with mcap_file.open('rb') as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        messages = sum(1 for _ in reader.iter_messages())
    assert messages == summary.statistics.message_count > 0
    with open_bag(bag) as reader_:
        assert sum(i.msgcount for i in reader_.topics.values()) == messages
    timing = json.loads((out / 'timing.json').read_text())
    assert timing['exit_code'] == 130 and 'calibration' in timing['stages']
    assert (out / 'calibration' / 'stereo.yaml').is_file()
