"""`lwrl view`: a saved Rerun recording in the viewer, or served to a browser."""

from lwrl.cli import fields


def add_parser(commands) -> None:
    view = commands.add_parser("view", help="open a saved Rerun recording")
    view.add_argument("path", metavar="PATH", help="an .rrd file (lwrl train --rrd)")
    view.add_argument("--web", action="store_true",
                      help="serve the web viewer on http://127.0.0.1 instead of a native window")
    view.add_argument("--port", type=fields.positive_int, help="web viewer port (default 9090)")
    view.set_defaults(run=view_recording)


def view_recording(args) -> int:
    """Open a saved Rerun recording in the viewer, or serve the web viewer on 127.0.0.1."""
    from lwrl.viz import rerun as viz

    try:
        return viz.view(args.path, web=args.web, web_port=args.port)
    except FileNotFoundError as error:
        raise ValueError(str(error)) from None
    except viz.ViewerUnavailable as error:
        raise ValueError(str(error)) from None
