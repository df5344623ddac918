"""`lwrl view`: a saved Rerun recording in the viewer, served to a browser, or rendered to a
picture of its first screen."""

import argparse
import re
from pathlib import Path

from lwrl.cli import fields


def window_size(text: str) -> str:
    """An argparse type: `WIDTHxHEIGHT` in the viewer's logical pixels."""
    if not re.fullmatch(r"[1-9]\d{1,4}x[1-9]\d{1,4}", text):
        raise argparse.ArgumentTypeError(f"must be WIDTHxHEIGHT, e.g. 1280x800; got {text!r}")
    return text


def add_parser(commands) -> None:
    view = commands.add_parser("view", help="open a saved Rerun recording",
                               description="Open a saved Rerun recording in the viewer; serve "
                                           "it to a browser (--web); or render its first "
                                           "screen headless to a PNG (--screenshot).")
    view.add_argument("path", metavar="PATH", help="an .rrd file (lwrl train --rrd)")
    view.add_argument("--web", action="store_true",
                      help="serve the web viewer on http://127.0.0.1 instead of a native window "
                           "(the address to open is printed)")
    view.add_argument("--port", type=fields.positive_int,
                      help="web viewer port (default 9090)")
    view.add_argument("--screenshot", metavar="PNG",
                      help="render the first screen headless to PNG and exit (needs a Vulkan "
                           "driver, e.g. Mesa's lavapipe: apt-get install mesa-vulkan-drivers)")
    view.add_argument("--window-size", type=window_size, default="1280x800", metavar="WxH",
                      help="the headless window for --screenshot (default 1280x800; the PNG "
                           "has twice as many pixels each way)")
    view.set_defaults(run=view_recording)


def view_recording(args) -> int:
    """Open a saved Rerun recording in the viewer, serve the web viewer on 127.0.0.1, or
    render its first screen to a PNG."""
    from lwrl.viz import rerun as viz

    if not Path(args.path).is_file():
        raise ValueError(f"no such recording: {args.path}")
    try:
        if args.screenshot:
            png = viz.screenshot(args.path, args.screenshot, window_size=args.window_size)
            print(f"wrote {png}: the first screen of {args.path} in a {args.window_size} window")
            return 0
        if args.web:
            web_port, grpc_port = args.port or viz.WEB_PORT, viz.free_port()
            print(f"serving {args.path} to the web viewer: open "
                  f"{viz.web_viewer_url(web_port, grpc_port)} (Ctrl-C stops)", flush=True)
            return viz.view(args.path, web=True, web_port=web_port, grpc_port=grpc_port)
        return viz.view(args.path)
    except FileNotFoundError as error:
        raise ValueError(str(error)) from None
    except viz.ViewerUnavailable as error:
        raise ValueError(str(error)) from None
