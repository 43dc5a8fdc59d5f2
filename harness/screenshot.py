"""`python -m harness.screenshot RUN_DIR/trials.rrd OUT.png`: a picture of a recording as the
real Rerun viewer draws it (its web viewer, served by the `rerun` CLI that rerun-sdk
installs, in headless Chromium with a software renderer), at a chosen point of the `query`
timeline.

Optional tools, not dependencies of the project: `pip install playwright` and a Chromium
(`apt-get install chromium`, or `playwright install chromium`; `--chromium PATH` picks one).
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.parse
from pathlib import Path


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def viewer_url(web_port: int, grpc_port: int) -> str:
    proxy = urllib.parse.quote(f"rerun+http://127.0.0.1:{grpc_port}/proxy", safe="")
    return f"http://127.0.0.1:{web_port}?url={proxy}"


def screenshot(rrd: Path, out: Path, chromium: str | None, wait_s: float, size: tuple[int, int]) -> None:
    from playwright.sync_api import sync_playwright

    rerun = shutil.which("rerun")
    if rerun is None:
        raise RuntimeError("the `rerun` CLI (installed with rerun-sdk) is not on PATH")
    web, grpc = _free_port(), _free_port()
    server = subprocess.Popen(
        [rerun, "--web-viewer", "--web-viewer-port", str(web), "--port", str(grpc), str(rrd)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        # `rerun` on PATH is a wrapper that starts the viewer binary as its child: a group of
        # their own lets the whole group be stopped (terminating the wrapper alone left the
        # viewer running, at ~80% CPU, after every screenshot)
        start_new_session=True,
    )
    try:
        time.sleep(3)  # the server loads the recording
        with sync_playwright() as p:
            args = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"]
            browser = p.chromium.launch(executable_path=chromium, args=args)
            page = browser.new_page(viewport={"width": size[0], "height": size[1]})
            page.goto(viewer_url(web, grpc))
            time.sleep(wait_s)  # the viewer's wasm compiles, then draws with a software renderer
            page.screenshot(path=str(out))
            browser.close()
    finally:
        try:
            os.killpg(server.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        server.wait(timeout=10)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.screenshot", description=__doc__.splitlines()[0])
    ap.add_argument("rrd", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--chromium", default=shutil.which("chromium"), help="the Chromium executable")
    ap.add_argument("--wait", type=float, default=60.0, help="seconds for the viewer to load and draw")
    ap.add_argument("--size", type=int, nargs=2, default=(1600, 1000))
    args = ap.parse_args(argv)
    if not args.rrd.is_file():
        print(f"screenshot: no recording at {args.rrd}", file=sys.stderr)
        return 1
    try:
        screenshot(args.rrd, args.out, args.chromium, args.wait, tuple(args.size))
    except ImportError:
        print("screenshot: needs playwright (pip install playwright) and a Chromium", file=sys.stderr)
        return 1
    except Exception as e:  # noqa: BLE001 - a browser or viewer failure, reported in one line
        print(f"screenshot: {type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}", file=sys.stderr)
        return 1
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
