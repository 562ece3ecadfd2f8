"""``dempath click BAG_OR_FOLDER``: the paper's Image Clicker as a local web page.

Opens the frames, resumes the click file if it exists (``--out``, default ``clicks.csv``),
merges ``--import`` files, and serves the page on 127.0.0.1 until Ctrl-C. Every click is saved
at once; ``dempath_clicker`` (a node) publishes the file as ``dempath_msgs/PixelPoints``. One
session holds the click file (a second one on the same file is refused). The page's address,
printed here, carries the session token; binding another address than loopback needs
``--allow-remote``, warns, and prints the address other machines reach.
"""

from __future__ import annotations

import argparse
import csv
import logging
import sys
from pathlib import Path

from dempath_recon.clicker.click_csv import ClickBounds, parse_markers, read_clicks_text
from dempath_recon.clicker.clicks import ClickStore, click_file_lock
from dempath_recon.clicker.frames import open_frames
from dempath_recon.clicker.server import ClickServer, ClickSession, Detection, is_loopback
from dempath_recon.errors import ClickError

LOG = logging.getLogger(__name__)


def read_detections(path: Path, bounds: ClickBounds) -> dict[tuple[int, str], list[Detection]]:
    """Detections CSV ``frame,camera,marker,x,y[,confidence]`` (marker -1 or empty: unnumbered).

    Raises:
        ClickError: Unreadable file or a row that is not numbers.
    """
    out: dict[tuple[int, str], list[Detection]] = {}
    try:
        with path.open(newline='') as handle:
            for line, row in enumerate(csv.DictReader(handle), start=2):
                try:
                    key = (int(row['frame']), row['camera'].strip())
                    det = (int(row['marker'] or -1), float(row['x']), float(row['y']),
                           float(row.get('confidence') or 1.0))
                except (KeyError, TypeError, ValueError, AttributeError) as err:
                    msg = f'{path}: line {line}: not a detection row frame,camera,marker,x,y'
                    raise ClickError(msg) from err
                if key[1] in bounds.sizes and 0 <= key[0] < bounds.n_frames:
                    out.setdefault(key, []).append(det)
    except OSError as err:
        msg = f'{path}: cannot read detections ({err.strerror or err})'
        raise ClickError(msg) from err
    return out


def make_session(args: argparse.Namespace) -> ClickSession:
    """Frames, store (resumed), imports and detections of a ``dempath click`` run."""
    frames = open_frames(args.source, fps=args.fps)
    for warning in frames.warnings:
        print(f'warning: {warning}', file=sys.stderr)
    bounds = ClickBounds(len(frames.frames), frames.sizes, parse_markers(args.markers))
    store = ClickStore(Path(args.out).resolve(), bounds)
    resumed = store.load()
    for name in args.imports:
        try:
            text = Path(name).read_text()
        except (OSError, UnicodeDecodeError) as err:
            msg = f'{name}: cannot read ({err})'
            raise ClickError(msg) from err
        clicks = read_clicks_text(text, bounds, name)
        store.apply([(c.key, (c.x, c.y)) for c in clicks])
    detections = read_detections(Path(args.detections), bounds) if args.detections else {}
    print(f'{args.source}: {len(frames.frames)} frames of {", ".join(frames.cameras)}; '
          f'{resumed} clicks resumed from {store.path}' if resumed else
          f'{args.source}: {len(frames.frames)} frames of {", ".join(frames.cameras)}; '
          f'clicks go to {store.path}')
    return ClickSession(frames, store, detections)


def parser() -> argparse.ArgumentParser:
    """The command's arguments."""
    p = argparse.ArgumentParser(prog='dempath click', description=__doc__.split('\n')[0])
    p.add_argument('source', help='bag (CompressedImage/Image per camera) or folder of images')
    p.add_argument('--out', default='clicks.csv',
                   help="the session's click file, resumed if it exists (default clicks.csv)")
    p.add_argument('--port', type=int, default=8765, help='port (0: any free one)')
    p.add_argument('--host', default='127.0.0.1', help='address to bind (default localhost)')
    p.add_argument('--allow-remote', action='store_true',
                   help='allow a --host other than loopback (other machines can then reach '
                        'the images and, with the printed address, change the clicks)')
    p.add_argument('--markers', default='1-15', help="marker numbers (default the paper's 1-15)")
    p.add_argument('--fps', type=float, default=50.0, help='frame rate of a folder [1/s]')
    p.add_argument('--detections', help='CSV frame,camera,marker,x,y[,confidence] to overlay')
    p.add_argument('--import', dest='imports', action='append', default=[],
                   help='click CSV or per-particle CSV to merge (repeatable)')
    return p


def click_main(argv: list[str]) -> int:
    """``dempath click SOURCE``: click markers in a bag or frame folder in the browser.

    Serves the clicker until Ctrl-C; bad input gives one ``error:`` line and 1.
    """
    args = parser().parse_args(argv)
    if not is_loopback(args.host) and not args.allow_remote:
        print(f'error: --host {args.host}: serves beyond this machine; add --allow-remote to do '
              'it on purpose', file=sys.stderr)
        return 1
    try:
        if args.fps <= 0:
            msg = f'--fps: must be positive, got {args.fps}'
            raise ValueError(msg)
        with click_file_lock(Path(args.out).resolve()):
            return serve(args)
    except (ClickError, ValueError) as err:
        print('error: ' + ' '.join(str(err).split()), file=sys.stderr)
        return 1
    except OSError as err:
        print(f'error: {args.host}:{args.port}: cannot serve ({err.strerror or err})',
              file=sys.stderr)
        return 1


def serve(args: argparse.Namespace) -> int:
    """Open the session and serve it until Ctrl-C (the click file is held by the caller)."""
    session = make_session(args)
    server = ClickServer(session, args.host, args.port)
    if not is_loopback(args.host):
        print(f'warning: --host {args.host}: the clicker is reachable from other machines; '
              'anyone who reaches the port sees the images, and anyone with the address below '
              '(it carries the session token) can change the clicks', file=sys.stderr)
    print(f'clicker at {server.url} (Ctrl-C to stop; every click is saved at once)', flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
    print(f'{len(session.store.points)} clicks in {session.store.path}')
    return 0
