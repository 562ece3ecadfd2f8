"""The clicker's server: only session paths answer, only the click file changes, nothing is lost.

Runs ``dempath click`` as a user does (a real process on 127.0.0.1) and talks HTTP to it.
"""

from __future__ import annotations

import http.client
import json
import os
import re
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

DEMPATH = str(Path(sys.executable).with_name('dempath'))

def _default_sigint() -> None:
    """In the child: SIGINT back to its default (a shell running the suite in the background
    starts it ignored, and a process that inherits that ignores Ctrl-C)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)



@pytest.fixture
def frames(tmp_path: Path) -> Path:
    """A folder of two cameras x three 320x240 frames."""
    for camera in ('cam_side', 'cam_front'):
        (tmp_path / 'frames' / camera).mkdir(parents=True)
        for k in range(3):
            cv2.imwrite(str(tmp_path / 'frames' / camera / f'{k}.jpg'),
                        np.full((240, 320, 3), 40 * k, np.uint8))
    return tmp_path / 'frames'


class Clicker:
    """A running ``dempath click`` process and an HTTP client for it."""

    def __init__(self, args: list[str], cwd: Path) -> None:
        self.proc = subprocess.Popen([DEMPATH, 'click', *args, '--port', '0'], cwd=cwd,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     preexec_fn=_default_sigint)
        assert self.proc.stdout is not None
        line = ''
        while 'clicker at' not in line:
            line = self.proc.stdout.readline()
            assert line, f'no server: {self.proc.stderr.read() if self.proc.stderr else ""}'
        self.line = line
        self.port = int(re.search(r':(\d+)/', line)[1])  # type: ignore[index]
        self.token = re.search(r'#token=([\w-]+)', line)[1]  # type: ignore[index]

    def request(self, method: str, path: str, body: object = None,
                headers: dict[str, str] | None = None) -> tuple[int, str]:
        """One request; (status, body text)."""
        conn = http.client.HTTPConnection('127.0.0.1', self.port, timeout=10)
        conn.request(method, path, json.dumps(body) if body is not None else None,
                     headers or {})
        reply = conn.getresponse()
        result = reply.status, reply.read().decode(errors='replace')
        conn.close()
        return result

    def post(self, path: str, body: object) -> tuple[int, str]:
        """A POST with the session token."""
        return self.request('POST', path, body, {'X-Clicker-Token': self.token,
                                                 'Content-Type': 'application/json'})

    def stop(self, sig: int = signal.SIGINT) -> str:
        """Send ``sig``; return what the process wrote on stderr."""
        self.proc.send_signal(sig)
        _, err = self.proc.communicate(timeout=120)  # a guard: a loaded machine exits slowly
        return err


@pytest.fixture
def clicker(frames: Path, tmp_path: Path) -> Iterator[Clicker]:
    """``dempath click frames --out clicks.csv`` on a free port."""
    running = Clicker([str(frames), '--out', 'clicks.csv'], tmp_path)
    yield running
    if running.proc.poll() is None:
        running.stop(signal.SIGKILL)


def test_killed_server_loses_no_saved_click(clicker: Clicker, tmp_path: Path) -> None:
    """Every answered click is on disk: SIGKILL after the last one loses nothing."""
    for k, (x, y) in enumerate([(10.25, 20.5), (100.0, 50.75), (319.4, 239.4)]):
        status, _ = clicker.post('/api/click', {'frame': k, 'camera': k % 2, 'marker': k + 1,
                                                'x': x, 'y': y})
        assert status == 200
    clicker.stop(signal.SIGKILL)
    lines = (tmp_path / 'clicks.csv').read_text().splitlines()
    assert lines == ['frame,camera,marker,x,y', '0,cam_side,1,10.250,20.500',
                     '1,cam_front,2,100.000,50.750', '2,cam_side,3,319.400,239.400']


def test_paths_outside_the_session_are_refused(clicker: Clicker, tmp_path: Path) -> None:
    """A page request for a path outside the session: 403/404, one log line, no file read."""
    (tmp_path / 'secret.txt').write_text('do not serve')
    for path, status in [('/../secret.txt', 403), ('/%2e%2e/%2e%2e/etc/passwd', 403),
                         ('/image/0/..%2F..%2Fsecret.txt', 403), ('/secret.txt', 404),
                         ('/image/0/99', 404), ('/image/7/0', 404), ('/clicks.csv', 404)]:
        got, body = clicker.request('GET', path)
        assert got == status, f'{path}: {got}'
        assert 'do not serve' not in body and body.startswith('error: ')
    assert clicker.request('GET', '/image/1/2')[0] == 200
    err = clicker.stop()
    assert err.count('refused GET') == 7
    assert "refused GET '/../secret.txt' from 127.0.0.1: path outside the session" in err


def test_only_the_click_file_is_writable(clicker: Clicker, tmp_path: Path) -> None:
    """No token, a foreign Host, or an out-of-image click change nothing."""
    click = {'frame': 0, 'camera': 0, 'marker': 1, 'x': 5.0, 'y': 5.0}
    assert clicker.request('POST', '/api/click', click)[0] == 403
    assert clicker.request('POST', '/api/click', click, {'X-Clicker-Token': clicker.token,
                                                         'Host': 'evil.example:80'})[0] == 403
    status, body = clicker.post('/api/click', {**click, 'x': 400.0})
    assert status == 400
    assert json.loads(body)['error'] == ('error: click: point (400, 5) px is outside the '
                                         '320x240 image of cam_side')
    status, body = clicker.post('/api/import', {'name': '../../x.csv', 'text':
                                                'frame,camera,marker,x,y\n0,cam_side,99,1,1\n'})
    assert json.loads(body)['error'] == ('error: .._.._x.csv: line 2: marker 99 is not one of '
                                         'the markers 1-15')
    assert not (tmp_path / 'clicks.csv').exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ['.clicks.csv.lock', 'frames']


def test_import_export_and_resume(frames: Path, tmp_path: Path) -> None:
    """``--import`` merges a CSV; the export is the click file; a new session resumes it."""
    (tmp_path / 'old.csv').write_text('frame,camera,marker,x,y\n2,cam_front,4,12.5,13.5\n')
    first = Clicker([str(frames), '--out', 'c.csv', '--import', 'old.csv'], tmp_path)
    assert first.post('/api/click', {'frame': 1, 'camera': 0, 'marker': 2, 'x': 1.0,
                                     'y': 2.0})[0] == 200
    status, csv_text = first.request('GET', '/api/export')
    first.stop()
    assert status == 200 and csv_text == (tmp_path / 'c.csv').read_text()
    second = Clicker([str(frames), '--out', 'c.csv'], tmp_path)
    state = json.loads(second.request('GET', '/api/frame/2')[1])
    second.stop()
    assert state['clicks'] == [{'frame': 2, 'camera': 'cam_front', 'marker': 4, 'x': 12.5,
                                'y': 13.5}]
    assert state['n_clicks'] == 2


def test_bad_sources_give_one_line(tmp_path: Path) -> None:
    """Mixed image sizes and a bad click file to resume: exit 1 with one error line."""
    for k, size in enumerate([(40, 30), (41, 30)]):
        cv2.imwrite(str(tmp_path / f'{k}.png'), np.zeros((size[1], size[0], 3), np.uint8))
    done = subprocess.run([DEMPATH, 'click', str(tmp_path)], capture_output=True, text=True,
                          check=False, cwd=tmp_path, env={**os.environ})
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [
        f'error: {tmp_path}/1.png: 41x30 px, but the other images of {tmp_path.name} are 40x30 px '
        '(a session needs one size per camera)']
    (tmp_path / '1.png').unlink()
    (tmp_path / 'c.csv').write_text('frame,camera,marker,x,y\n0,' + tmp_path.name + ',1,50,5\n')
    done = subprocess.run([DEMPATH, 'click', str(tmp_path), '--out', 'c.csv'],
                          capture_output=True, text=True, check=False, cwd=tmp_path)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines()[-1:] == [
        f'error: {tmp_path}/c.csv: line 2: point (50, 5) px is outside the 40x30 image of '
        f'{tmp_path.name}']
    assert done.stderr.count('error:') == 1 and done.stderr.startswith('warning: ')


def test_token_is_never_served(clicker: Clicker) -> None:
    """The token is in the printed address's fragment only: no page or API answer holds it,
    whatever Host the client claims (it used to be in the page for Host: 127.0.0.1:PORT)."""
    assert '#token=' in clicker.line
    for path in ('/', '/clicker.js', '/api/session', '/api/frame/0'):
        for host in (f'127.0.0.1:{clicker.port}', f'localhost:{clicker.port}'):
            status, body = clicker.request('GET', path, headers={'Host': host})
            assert status == 200 and clicker.token not in body, path


def test_remote_host_needs_its_flag_and_warns(frames: Path, tmp_path: Path) -> None:
    """--host 0.0.0.0 alone is refused; with --allow-remote it warns and prints the address
    other machines use (not 127.0.0.1)."""
    done = subprocess.run([DEMPATH, 'click', str(frames), '--host', '0.0.0.0', '--port', '0'],
                          capture_output=True, text=True, check=False, cwd=tmp_path)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [
        'error: --host 0.0.0.0: serves beyond this machine; add --allow-remote to do it on '
        'purpose']
    from dempath_recon.clicker.server import reachable_address

    remote = Clicker([str(frames), '--host', '0.0.0.0', '--allow-remote'], tmp_path)
    assert f'http://{reachable_address()}:{remote.port}/#token=' in remote.line
    err = remote.stop()
    assert err.startswith('warning: --host 0.0.0.0: the clicker is reachable from other machines')


def test_second_session_on_one_click_file_is_refused(clicker: Clicker, frames: Path,
                                                     tmp_path: Path) -> None:
    """Two sessions on one click file used to lose clicks (last writer wins): the second is
    refused with one line naming the first one's process."""
    done = subprocess.run([DEMPATH, 'click', str(frames), '--out', 'clicks.csv', '--port', '0'],
                          capture_output=True, text=True, check=False, cwd=tmp_path)
    assert done.returncode == 1
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and 'another dempath click session (pid ' in lines[0]
    assert clicker.post('/api/click', {'frame': 0, 'camera': 0, 'marker': 1, 'x': 5.0,
                                       'y': 5.0})[0] == 200


def raw_post(clicker: Clicker, body: bytes, length: str) -> tuple[int, str]:
    """A POST with the token and a hand-made Content-Length."""
    conn = http.client.HTTPConnection('127.0.0.1', clicker.port, timeout=10)
    conn.putrequest('POST', '/api/click')
    for name, value in (('X-Clicker-Token', clicker.token), ('Content-Length', length),
                        ('Content-Type', 'application/json')):
        conn.putheader(name, value)
    conn.endheaders(body)
    reply = conn.getresponse()
    result = reply.status, reply.read().decode(errors='replace')
    conn.close()
    return result


def test_malformed_bodies_are_400_without_a_traceback(clicker: Clicker) -> None:
    """A JSON list, frame 1e999 and Content-Length abc: 400 with one line each, and the server
    goes on (they used to drop the connection with a traceback on the server)."""
    for body, length in ((b'[1, 2]', '6'), (b'{"frame": 1e999, "camera": 0, "marker": 1, '
                                             b'"x": 1, "y": 1}', None),
                         (b'{}', 'abc')):
        status, text = raw_post(clicker, body, length or str(len(body)))
        assert status == 400 and 'error' in text, (body, text)
    assert clicker.post('/api/click', {'frame': 0, 'camera': 0, 'marker': 1, 'x': 5.0,
                                       'y': 5.0})[0] == 200
    err = clicker.stop()
    assert 'Traceback' not in err


def test_idle_connection_is_closed(frames: Path, tmp_path: Path,
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A client that connects and sends nothing is disconnected after the idle timeout."""
    import socket
    import threading

    from dempath_recon.clicker import server as server_module
    from dempath_recon.clicker.click_csv import ClickBounds
    from dempath_recon.clicker.clicks import ClickStore
    from dempath_recon.clicker.frames import open_frames

    monkeypatch.setattr(server_module.ClickHandler, 'timeout', 0.5)
    opened = open_frames(frames)
    store = ClickStore(tmp_path / 'c.csv', ClickBounds(len(opened.frames), opened.sizes,
                                                       frozenset(range(1, 16))))
    server = server_module.ClickServer(server_module.ClickSession(opened, store), port=0)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        with socket.create_connection(('127.0.0.1', server.port), timeout=20) as idle:
            assert idle.recv(1) == b''  # closed by the server, not by our own timeout
    finally:
        server.shutdown()
        server.server_close()
