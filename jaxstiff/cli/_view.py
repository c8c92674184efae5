"""``jaxstiff view``: look at a result in the browser (viser), or write a static HTML page.

Examples::

    jaxstiff view shape.npz                      # http://127.0.0.1:8080, Ctrl-C to stop
    jaxstiff view lwr.npz --port 8090            # a csc result: K_xd and K_C at the TCP
    jaxstiff view runs/quick --row 17            # one row of a sweep folder
    jaxstiff view shape.npz --html shape.html    # a page that opens from disk, no server
    jaxstiff view shape.npz --png shape.png --waypoint 30 --all   # a screenshot (headless Chromium)

The viewer reads the file and runs numpy forward kinematics; nothing is compiled. Needs the
``view`` extra (``pip install "jaxstiff[view]"``: viser); ``--png`` also needs Chromium or Chrome
(``apt-get install chromium``; :mod:`jaxstiff.view._png` says which flags it runs it with).
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from ._common import check_out_path, command, reads, writes


def add_result_flags(
    p: argparse.ArgumentParser, what: str = "a shape or csc result file (.npz), or a sweep folder with --row"
) -> None:
    """The flags every command that reads a result shares: the file (``what`` it may be), --row, --urdf."""
    reads(p.add_argument("result", metavar="RESULT", help=what))
    p.add_argument("--row", type=int, default=None, help="the row (row_id) of a sweep folder to read")
    reads(
        p.add_argument(
            "--urdf", default=None, help="the robot's URDF if the recorded path moved (default: the path in the file)"
        )
    )


def check_port(host: str, port: int) -> None:
    """Refuse a ``--port`` outside 1-65535, a ``--host`` that is not an address of this machine,
    and a port already taken, before the viewer starts (viser retries the next port for ever on
    an address it cannot bind, and leaves a thread traceback and no exit for a port over 65535)."""
    import socket

    if not 1 <= port <= 65535:
        raise ValueError(f"--port must be a TCP port number 1-65535, got {port}")
    try:
        family, kind, proto, _, addr = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0]
    except (socket.gaierror, UnicodeError) as e:
        raise ValueError(f"--host {host!r}: not an address to serve on ({getattr(e, 'strerror', None) or e})") from None
    with socket.socket(family, kind, proto) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server binds (a closed viewer's port is free)
        try:
            s.bind(addr)
        except OSError as e:
            raise ValueError(
                f"--port {port}: cannot serve on {host}:{port}: {e.strerror or e} (another viewer running? "
                "choose another --port)"
            ) from None


def viser_or_error() -> Any:
    """``import viser``, or a ValueError telling how to install it."""
    try:
        import viser
    except ImportError:
        raise ValueError('jaxstiff view needs viser: pip install "jaxstiff[view]" (or pip install viser)') from None
    return viser


def _check_view_outputs(args: argparse.Namespace) -> None:
    """--html and --png before anything starts (the browser, the scene): a folder, a missing folder
    or a name of another format (an HTML page in ``v.png``) is refused here."""
    import os

    for flag, out, like in (("--html", args.html, "shape.html"), ("--png", args.png, "shape.png")):
        if out:
            check_out_path(out, flag, like=like)
            want = (".html", ".htm") if flag == "--html" else (".png",)
            if os.path.splitext(out)[1].lower() not in want:
                raise ValueError(f"{flag} {out}: the file is {want[0][1:].upper()}; name it like {like}")


@command("view", "look at a result in the browser: arm, path, stiffness ellipsoids (viser)")
def _add_view(p: argparse.ArgumentParser) -> Any:
    add_result_flags(p)
    p.add_argument("--port", type=int, default=8080, help="port of the viewer's web server")
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (0.0.0.0: every interface)")
    writes(
        p.add_argument(
            "--html", default=None, metavar="OUT.html", help="write a static page (opens from disk) and exit"
        )
    )
    writes(
        p.add_argument("--png", default=None, metavar="OUT.png", help="write a screenshot (headless Chromium) and exit")
    )
    p.add_argument("--path", type=int, default=0, help="the path of a batch result shown first (0-based)")
    p.add_argument("--waypoint", type=int, default=0, help="the waypoint (csc: step) shown first (0-based)")
    p.add_argument(
        "--all", action="store_true", dest="all_ellipsoids", help="start with 'all ellipsoids along the path' on"
    )
    p.add_argument(
        "--browser",
        default=None,
        metavar="PATH",
        help="--png: the Chromium/Chrome to run (default: $JAXSTIFF_CHROMIUM, then chromium on PATH)",
    )
    p.add_argument("--size", default="1200x800", metavar="WxH", help="--png: picture size in pixels")
    p.add_argument(
        "--timeout", type=float, default=180.0, metavar="S", help="--png: give up after S seconds, nothing written"
    )
    p.add_argument(
        "--scale",
        type=float,
        default=None,
        help="ellipsoid scale, N/m of stiffness per metre of the scene (the arm's metres, not of the screen: the view zooms) (default: a round number that draws the largest semi-axis about 0.21 x the arm's length long, 25 cm on the LWR)",
    )
    p.add_argument("--every", type=int, default=1, help="'all ellipsoids': draw every N-th waypoint's (N >= 1)")

    def run(args: argparse.Namespace) -> int:
        import os
        import tempfile

        from jaxstiff.view._data import load_view_data

        viser_or_error()
        if args.scale is not None and not (math.isfinite(args.scale) and args.scale > 0):
            raise ValueError(f"--scale must be a positive finite number (N/m per m), got {args.scale}")
        if args.every < 1:
            raise ValueError(f"--every must be a whole number >= 1 (every N-th waypoint's ellipsoid), got {args.every}")
        _check_view_outputs(args)
        if not (args.html or args.png):
            check_port(args.host, args.port)
        browser, size = None, (0, 0)
        if args.png:
            from jaxstiff.view._png import find_browser

            size = _size(args.size)
            if not (math.isfinite(args.timeout) and args.timeout > 0):
                raise ValueError(f"--timeout must be a positive number of seconds, got {args.timeout}")
            browser = find_browser(args.browser)  # no browser: said before the result is read
        data = load_view_data(args.result, row=args.row, urdf=args.urdf)
        if not 0 <= args.path < data.B:
            raise ValueError(f"--path {args.path}: the result has {data.B} path(s), 0..{data.B - 1}")
        if not 0 <= args.waypoint < data.P:
            raise ValueError(f"--waypoint {args.waypoint}: the result has {data.P} waypoints, 0..{data.P - 1}")
        if args.html or args.png:
            from jaxstiff.view._static import write_html

            start = {"b": args.path, "waypoint": args.waypoint, "all_ellipsoids": args.all_ellipsoids}
            with tempfile.TemporaryDirectory(prefix="jaxstiff-view-") as tmp:
                page = args.html or os.path.join(tmp, "page.html")
                write_html(data, page, n_per_m=args.scale, every=args.every, **start)
                if args.html:
                    print(f"wrote {args.html}")
                if args.png:
                    from jaxstiff.view._png import BrowserError, screenshot

                    try:
                        screenshot(page, args.png, browser=browser, width=size[0], height=size[1], timeout=args.timeout)
                    except BrowserError as e:  # the environment's browser, not the command: one line, exit 2
                        raise OSError(f"--png: {e}; nothing written") from None
                    print(f"wrote {args.png}")
            return 0
        from jaxstiff.view._app import open_viewer, serve_forever

        viewer = open_viewer(data, port=args.port, host=args.host, n_per_m=args.scale, every=args.every)
        viewer.start_at(args.path, args.waypoint, args.all_ellipsoids)
        port = viewer.server.get_port()
        print(f"jaxstiff view: http://{args.host}:{port}  ({data.kind}, {data.B} x {data.P}; Ctrl-C to stop)")
        sys.stdout.flush()
        serve_forever(viewer)
        return 0

    return run


def _size(text: str) -> tuple[int, int]:
    """``"1200x800"`` -> (1200, 800); a one-line error otherwise."""
    w, sep, h = text.lower().partition("x")
    try:
        size = (int(w), int(h))
    except ValueError:
        size = (0, 0)
    if not sep or not (64 <= size[0] <= 8192 and 64 <= size[1] <= 8192):
        raise ValueError(f"--size: expected WIDTHxHEIGHT in pixels (64 to 8192), like 1200x800, got {text!r}")
    return size
