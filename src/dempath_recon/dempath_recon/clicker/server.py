"""The clicker's local web server: one page, the session's frames, and its click file.

Standard library only (``http.server.ThreadingHTTPServer``), bound to 127.0.0.1 by default.
What the page can reach is a fixed table of routes; nothing it sends is used as a path:

- ``GET /``, ``/clicker.js``, ``/clicker.css``: the page (from this package, by fixed name);
- ``GET /api/session``, ``/api/frame/<k>``, ``/image/<camera index>/<k>``, ``/api/export``;
- ``POST /api/click``, ``/api/delete``, ``/api/undo``, ``/api/import``, ``/api/accept``.

Frames and cameras are integer indices into the session's :class:`FrameSet`. Every other path
gets 404 (403 for a path climbing out with ``..``) and one log line. A POST must carry the
session's random token in ``X-Clicker-Token`` (a page of another site cannot send that header
without a CORS preflight, which this server never grants) and a ``Host`` naming this server
(against DNS rebinding). The token is never served: it is printed on the terminal in the page's
address fragment (``#token=...``, which browsers do not send), so a client that forges a
``Host`` header cannot read it. A malformed body (not a JSON object, numbers out of range, a
non-numeric ``Content-Length``) is answered 400 with one line; a connection idle for
``IDLE_TIMEOUT_S`` is closed. The only file written is the session's click file, atomically,
after every change (:class:`dempath_recon.clicker.clicks.ClickStore`).
"""

from __future__ import annotations

import json
import logging
import re
import secrets
from dataclasses import dataclass, field
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any
from urllib.parse import unquote, urlsplit

from dempath_recon.clicker.click_csv import Click, describe, read_clicks_text
from dempath_recon.clicker.clicks import ClickStore
from dempath_recon.clicker.frames import FrameSet
from dempath_recon.errors import ClickError

LOG = logging.getLogger(__name__)
STATIC = {'/': ('index.html', 'text/html; charset=utf-8'),
          '/clicker.js': ('clicker.js', 'text/javascript; charset=utf-8'),
          '/clicker.css': ('clicker.css', 'text/css; charset=utf-8')}
Detection = tuple[int, float, float, float]  # marker (-1: none), x, y [px], confidence
MAX_BODY = 16 * 1024 * 1024  # largest POST body (an imported CSV) [bytes]
IDLE_TIMEOUT_S = 30.0  # a connection that sends nothing for this long is closed [s]
LOOPBACK = ('127.0.0.1', 'localhost', '::1')


@dataclass
class ClickSession:
    """Everything one ``dempath click`` serves.

    Attributes:
        frames: The session's images.
        store: Its clicks and click file.
        detections: Automatic detections per (frame, camera) to show and accept.
        token: Random secret the page sends with every change.
    """

    frames: FrameSet
    store: ClickStore
    detections: dict[tuple[int, str], list[Detection]] = field(default_factory=dict)
    token: str = field(default_factory=lambda: secrets.token_urlsafe(24))

    def summary(self) -> dict[str, Any]:
        """The page's start-up data."""
        bounds = self.store.bounds
        return {'source': self.frames.source.name, 'cameras': list(self.frames.cameras),
                'sizes': [list(self.frames.sizes[c]) for c in self.frames.cameras],
                'n_frames': len(self.frames.frames), 'markers': sorted(bounds.markers),
                'markers_text': describe(bounds.markers), 'warnings': self.frames.warnings,
                'click_file': self.store.path.name}

    def frame_state(self, k: int) -> dict[str, Any]:
        """Clicks, detections and stamps of frame ``k``."""
        images = self.frames.frames[k]
        return {'frame': k,
                'clicks': [c._asdict() for c in self.store.clicks(k)],
                'detections': [{'camera': cam, 'marker': m, 'x': x, 'y': y, 'confidence': s}
                               for cam in self.frames.cameras
                               for m, x, y, s in self.detections.get((k, cam), [])],
                'stamps': [None if (im := images.get(c)) is None else im.stamp_s
                           for c in self.frames.cameras],
                'n_clicks': len(self.store.points), 'can_undo': bool(self.store.history)}

    def accept(self, k: int, camera: str) -> int:
        """Take the numbered detections of a frame and camera as clicks (one undoable action)."""
        sizes = self.store.bounds
        changes = [((k, camera, m), (x, y)) for m, x, y, _ in self.detections.get((k, camera), [])
                   if m in sizes.markers and (k, camera, m) not in self.store.points]
        self.store.apply(changes)
        return len(changes)


class ClickHandler(BaseHTTPRequestHandler):
    """Answers the page's requests for one :class:`ClickSession` (``server.session``)."""

    server: ClickServer
    server_version = 'dempath-clicker'
    timeout = IDLE_TIMEOUT_S  # socket timeout: idle (or slow-loris) connections are closed

    def log_message(self, format: str, *args: Any) -> None:
        """Route the access log to logging (debug) instead of stderr."""
        LOG.debug('%s %s', self.address_string(), format % args)

    @property
    def session(self) -> ClickSession:
        """The session this server serves."""
        return self.server.session

    def refuse(self, status: HTTPStatus, why: str) -> None:
        """Answer an error status with a one-line text body, and log it."""
        LOG.warning('refused %s %r from %s: %s', self.command, self.path, self.client_address[0],
                    why)
        self.send_text(status, f'error: {self.path}: {why}\n', 'text/plain; charset=utf-8')

    def send_text(self, status: HTTPStatus, body: str | bytes, kind: str,
                  extra: dict[str, str] | None = None) -> None:
        """Send a complete response that no browser caches or sniffs."""
        data = body.encode() if isinstance(body, str) else body
        self.send_response(status)
        self.send_header('Content-Type', kind)
        self.send_header('Content-Length', str(len(data)))
        self.send_header('Cache-Control', 'no-store')
        self.send_header('X-Content-Type-Options', 'nosniff')
        for name, value in (extra or {}).items():
            self.send_header(name, value)
        self.end_headers()
        self.wfile.write(data)

    def send_json(self, value: Any, status: HTTPStatus = HTTPStatus.OK) -> None:
        """Send a JSON value."""
        self.send_text(status, json.dumps(value), 'application/json')

    def route_path(self) -> str | None:
        """The request's path if it may be answered, else None after refusing it."""
        raw = urlsplit(self.path).path
        if '..' in unquote(raw) or '\\' in unquote(raw) or '//' in raw:
            self.refuse(HTTPStatus.FORBIDDEN, 'path outside the session')
            return None
        if self.headers.get('Host', '') not in self.server.hosts:
            self.refuse(HTTPStatus.FORBIDDEN, f'host {self.headers.get("Host")!r} is not this '
                        'server')
            return None
        return raw

    def do_GET(self) -> None:
        """Page, session data, frame state, images and the CSV export."""
        path = self.route_path()
        if path is None:
            return
        if path in STATIC:
            name, kind = STATIC[path]
            text = resources.files('dempath_recon.clicker').joinpath('web', name).read_text()
            self.send_text(HTTPStatus.OK, text, kind)
        elif path == '/api/session':
            self.send_json(self.session.summary())
        elif path == '/api/export':
            self.send_text(HTTPStatus.OK, self.session.store.path.read_bytes()
                           if self.session.store.path.exists() else b'frame,camera,marker,x,y\n',
                           'text/csv', {'Content-Disposition':
                                        f'attachment; filename="{self.session.store.path.name}"'})
        elif match := re.fullmatch(r'/api/frame/(\d{1,9})', path):
            k = self.frame_index(match[1])
            if k is not None:
                self.send_json(self.session.frame_state(k))
        elif match := re.fullmatch(r'/image/(\d{1,3})/(\d{1,9})', path):
            self.send_image(int(match[1]), match[2])
        else:
            self.refuse(HTTPStatus.NOT_FOUND, 'not a path of this session')

    def frame_index(self, text: str) -> int | None:
        """A valid frame index, or None after a 404."""
        k = int(text)
        if k >= len(self.session.frames.frames):
            self.refuse(HTTPStatus.NOT_FOUND, f'no frame {k}')
            return None
        return k

    def send_image(self, camera: int, frame: str) -> None:
        """The encoded image of camera index ``camera`` at frame ``frame``."""
        k = self.frame_index(frame)
        cameras = self.session.frames.cameras
        if k is None:
            return
        image = self.session.frames.frames[k].get(cameras[camera]) if camera < len(cameras) \
            else None
        if image is None:
            self.refuse(HTTPStatus.NOT_FOUND, f'no image of camera {camera} at frame {k}')
            return
        self.send_text(HTTPStatus.OK, image.data, image.mime)

    def do_POST(self) -> None:
        """Changes to the session's clicks (token required)."""
        path = self.route_path()
        if path is None:
            return
        if not secrets.compare_digest(self.headers.get('X-Clicker-Token', ''),
                                      self.session.token):
            self.refuse(HTTPStatus.FORBIDDEN, 'missing or wrong session token')
            return
        text = self.headers.get('Content-Length') or '0'
        length = int(text) if text.isdigit() else -1
        if length < 0:
            self.close_connection = True  # the body's end is unknown: nothing more to read
            self.refuse(HTTPStatus.BAD_REQUEST, f'Content-Length {text!r} is not a byte count')
            return
        if length > MAX_BODY:
            self.close_connection = True
            self.refuse(HTTPStatus.REQUEST_ENTITY_TOO_LARGE, f'body of {length} bytes')
            return
        try:
            body = json.loads(self.rfile.read(length) or b'{}')
            if not isinstance(body, dict):
                msg = f'{path}: the body must be a JSON object, got {type(body).__name__}'
                raise ClickError(msg)
            self.send_json(self.change(path, body))
        except ClickError as err:
            LOG.warning('%s', err)
            self.send_json({'error': f'error: {err}'}, HTTPStatus.BAD_REQUEST)
        except (ValueError, KeyError, TypeError, IndexError, OverflowError) as err:
            self.send_json({'error': f'error: {path}: bad request ({err})'},
                           HTTPStatus.BAD_REQUEST)

    def change(self, path: str, body: dict[str, Any]) -> dict[str, Any]:
        """Apply one POST and return the frame's new state."""
        session, store = self.session, self.session.store
        cameras = session.frames.cameras
        frame = int(body.get('frame', 0))
        if path == '/api/click':
            store.set(Click(frame, cameras[int(body['camera'])], int(body['marker']),
                            float(body['x']), float(body['y'])))
        elif path == '/api/delete':
            store.apply([((frame, cameras[int(body['camera'])], int(body['marker'])), None)])
        elif path == '/api/undo':
            store.undo()
        elif path == '/api/accept':
            session.accept(frame, cameras[int(body['camera'])])
        elif path == '/api/import':
            name = re.sub(r'[^\w.\-]', '_', str(body.get('name', 'import.csv')))[:100]
            clicks = read_clicks_text(str(body['text']), store.bounds, name)
            store.apply([(c.key, (c.x, c.y)) for c in clicks])
        else:
            msg = f'{path}: not a path of this session'
            raise ClickError(msg)
        return session.frame_state(min(max(frame, 0), len(session.frames.frames) - 1))


class ClickServer(ThreadingHTTPServer):
    """A threading HTTP server holding its session and the Host names it answers to."""

    daemon_threads = True

    def __init__(self, session: ClickSession, host: str = '127.0.0.1', port: int = 8765) -> None:
        super().__init__((host, port), ClickHandler)
        self.session = session
        bound = self.server_address[1]
        names = {host, 'localhost', '127.0.0.1', '[::1]'}
        if host in ('0.0.0.0', '::'):
            names.add(reachable_address())
        self.hosts = {f'{name}:{bound}' for name in names} | names
        self.port = int(bound)

    @property
    def url(self) -> str:
        """The page's address with the session token in its fragment (print it, never serve
        it); for a server bound to every interface, the address others reach it at."""
        host = str(self.server_address[0])
        if host in ('0.0.0.0', '::'):
            host = reachable_address()
        return f'http://{host}:{self.port}/#token={self.session.token}'


def is_loopback(host: str) -> bool:
    """Whether binding ``host`` keeps the server on this machine."""
    return host in LOOPBACK or host.startswith('127.')


def reachable_address() -> str:
    """This machine's address on its default route (what another machine would use), or
    127.0.0.1 when it has none. No packet is sent: a UDP socket only picks its route."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(('192.0.2.1', 9))  # TEST-NET-1: never routed, only looked up
            return str(probe.getsockname()[0])
        except OSError:
            return '127.0.0.1'
