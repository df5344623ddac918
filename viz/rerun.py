"""lwrl's Rerun entry points: open a recording, log a task, its episodes, value functions and
learning curves, send the layout, and view or render a saved `.rrd`.

    from lwrl.viz import rerun as viz
    rec = viz.open_recording("lwrl", rrd_path="run.rrd")       # spawn=True for a live viewer
    viz.send_blueprint(rec, "cartpole.balance")
    viz.log_task_scene(rec, "cartpole.balance")                   # once: static geometry
    viz.log_episode(rec, recording)                               # an EpisodeRecording
    viz.log_value_function(rec, "cartpole.balance", agents, recording.weights,   # Agents
                           recording.episode)
    viz.log_learning_curves(rec, results, config.seeds)           # an EpisodeResults
    viz.close_recording(rec)                                      # finishes the .rrd
    viz.view("run.rrd")                                           # or web=True

Timelines and entity paths are the constants of `viz.names`. Every per-step series goes in
with one `rr.send_columns` per entity; nothing here touches the stream's own clock
(`set_time`), and the only state is the stream handed in. Servers bind 127.0.0.1 only.
"""

import contextlib
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse
import uuid
import warnings
from pathlib import Path

import mujoco
import numpy as np
import rerun as rr

from lwrl.viz.blueprint import blueprint, send_blueprint
from lwrl.viz.columns import episode_indexes
from lwrl.viz.scene import load_model, log_scene_poses, log_task_scene
from lwrl.viz.series import log_learning_curves, log_signals
from lwrl.viz.value import log_value_function, log_value_path

BIND = "127.0.0.1"
"""The only address lwrl's viewers and servers listen on."""
APPLICATION_ID = "lwrl"
RRD_MAGIC = b"RRF2"
"""The first bytes of an .rrd file (Rerun's encoding)."""
SPAWN_TIMEOUT = 15.0
"""Seconds to wait for a spawned viewer to listen."""


class ViewerUnavailable(RuntimeError):
    """No Rerun viewer can be started here (no display, or no `rerun` binary)."""


def rerun_binary() -> str:
    """The path of the `rerun` executable shipped with rerun-sdk (the `rerun_cli` package)."""
    try:
        import rerun_cli

        bundled = Path(rerun_cli.__file__).with_name("rerun" + (".exe" if os.name == "nt" else ""))
        if bundled.exists():
            return str(bundled)
    except ImportError:
        pass
    found = shutil.which("rerun")
    if found is None:
        raise ViewerUnavailable("the rerun executable was not found (install rerun-sdk)")
    return found


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket() as probe:
        probe.bind((BIND, 0))
        return probe.getsockname()[1]


def has_display() -> bool:
    """True where a native viewer window can open (a display on Linux; always elsewhere)."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def spawn_viewer(port: int | None = None, memory_limit: str = "75%") -> str:
    """Start a native viewer listening on 127.0.0.1 (detached: it outlives this process) and
    return its gRPC URL; raises `ViewerUnavailable` without a display or when it does not
    come up within `SPAWN_TIMEOUT` seconds."""
    if not has_display():
        raise ViewerUnavailable("no display (DISPLAY / WAYLAND_DISPLAY unset): cannot open a "
                                "viewer window; save to an .rrd and `lwrl view` it elsewhere")
    port = free_port() if port is None else int(port)
    process = subprocess.Popen(
        [rerun_binary(), "--bind", BIND, "--port", str(port), "--memory-limit", memory_limit,
         "--expect-data-soon"],
        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        start_new_session=True, env={**os.environ, "RERUN_APP_ONLY": "true"})
    deadline = time.monotonic() + SPAWN_TIMEOUT
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise ViewerUnavailable(f"the viewer exited at once (code {process.returncode})")
        try:
            with socket.create_connection((BIND, port), timeout=0.2):
                return f"rerun+http://{BIND}:{port}/proxy"
        except OSError:
            time.sleep(0.1)
    process.terminate()
    raise ViewerUnavailable(f"the viewer did not listen on {BIND}:{port} within {SPAWN_TIMEOUT:g} s")


def open_recording(application_id: str = APPLICATION_ID, rrd_path=None, spawn: bool = False, *,
                   serve_port: int | None = None, recording_id: str | None = None) -> rr.RecordingStream:
    """A new recording stream writing to every sink asked for:

    - `rrd_path`: an .rrd file (overwritten; complete once `close_recording` is called);
    - `spawn=True`: a native viewer started for it, on 127.0.0.1 and a free port;
    - `serve_port`: a gRPC server on 127.0.0.1:`serve_port` that viewers connect to
      (`rerun rerun+http://127.0.0.1:PORT/proxy`); it buffers everything for late viewers.

    When `spawn=True` but no viewer can be started (no display, no binary): with another
    sink the stream goes on without a viewer and a `RuntimeWarning` says why; with no other
    sink it raises `ViewerUnavailable` (a stream writing nowhere would only fill memory).
    Asking for no sink at all raises a ValueError.
    """
    if rrd_path is None and not spawn and serve_port is None:
        raise ValueError("open_recording needs a sink: rrd_path, spawn=True or serve_port")
    sinks = []
    if rrd_path is not None:
        Path(rrd_path).parent.mkdir(parents=True, exist_ok=True)
        sinks.append(rr.FileSink(str(rrd_path)))
    if serve_port is not None:
        sinks.append(rr.GrpcServerSink(bind_ip=BIND, port=int(serve_port)))
    if spawn:
        try:
            sinks.append(rr.GrpcSink(spawn_viewer()))
        except ViewerUnavailable as error:
            if not sinks:
                raise
            warnings.warn(f"no Rerun viewer: {error}; recording to the other sinks only",
                          RuntimeWarning, stacklevel=2)
    rec = rr.RecordingStream(application_id, recording_id=recording_id or uuid.uuid4().hex)
    rec.set_sinks(*sinks)
    return rec


def close_recording(rec: rr.RecordingStream) -> None:
    """Flush everything and close the stream's sinks (an .rrd gets its footer: complete)."""
    rec.flush()
    rec.disconnect()


def log_episode(rec: rr.RecordingStream, recording, *, model: mujoco.MjModel | None = None,
                value_ranges=None) -> dict:
    """Log one `EpisodeRecording`: the moving bodies' poses (`scene/<body>`), its signals
    (`signals/...`) and, given `value_ranges` `(low, high)` (the ranges of the value images,
    the feature map's), its states over the value images (`value/state`,
    `value/trajectory`). Returns `{quantity: entity path}` of the signals plus `"bodies"`:
    the bodies' paths.

    `model`: the task's MuJoCo model from `load_model(task)`, compiled once by the caller
    for a run's episodes (compiling it costs 1 to 5 ms an episode otherwise)."""
    recording_checks(recording)
    paths = log_signals(rec, recording)
    indexes = episode_indexes(np.arange(recording.steps + 1), recording.timestep, recording.episode)
    paths["bodies"] = log_scene_poses(rec, recording, model, indexes)
    if value_ranges is not None:
        log_value_path(rec, recording, *value_ranges, indexes=indexes)
    return paths


def recording_checks(recording) -> None:
    """Raise a ValueError naming the first array of an `EpisodeRecording` of the wrong shape."""
    steps = len(recording.actions)
    dim = len(recording.state_names)
    expected = {"states": (steps + 1, dim), "observations": (steps + 1, dim),
                "rewards": (steps,), "td_errors": (steps,), "uptime": (steps,),
                "q_values": (steps + 1, len(recording.controls))}
    if np.shape(recording.q_values)[1:] == (0,):  # a learner without action values
        expected["q_values"] = (steps + 1, 0)
    for field, shape in expected.items():
        actual = np.shape(getattr(recording, field))
        if actual != shape:
            raise ValueError(f"recording.{field} must have shape {shape}; got {actual}")


def _run(command: list, timeout: float | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(command, stdin=subprocess.DEVNULL, timeout=timeout,
                          env={**os.environ, "RERUN_APP_ONLY": "true"})


WEB_PORT = 9090
"""The web viewer's default HTTP port (Rerun's)."""


def web_viewer_url(web_port: int = WEB_PORT, grpc_port: int = 9876) -> str:
    """The address a browser opens to see what `view(..., web=True)` serves: the web viewer
    at http://127.0.0.1:WEB_PORT, told where the recording is (`?url=` the gRPC proxy).
    Without `?url=` the web viewer opens on its welcome screen, with no recording."""
    proxy = urllib.parse.quote(f"rerun+http://{BIND}:{int(grpc_port)}/proxy", safe="")
    return f"http://{BIND}:{int(web_port)}/?url={proxy}"


def view_command(path, web: bool = False, web_port: int | None = None,
                 grpc_port: int | None = None) -> list:
    """The `rerun` command line `view` runs (every server bound to 127.0.0.1)."""
    command = [rerun_binary(), str(path), "--bind", BIND]
    if grpc_port is not None:
        command += ["--port", str(grpc_port)]
    if web:
        command += ["--web-viewer"]
        if web_port is not None:
            command += ["--web-viewer-port", str(web_port)]
    return command


def view(path, web: bool = False, web_port: int | None = None,
         grpc_port: int | None = None) -> int:
    """Open a saved .rrd: the native viewer (`rerun PATH --bind 127.0.0.1`), or with
    `web=True` the web viewer served at `web_viewer_url(web_port, grpc_port)` (`rerun PATH
    --web-viewer --bind 127.0.0.1`; Rerun also opens that address in the browser `$BROWSER`
    names, or the desktop's). Blocks until the viewer or server stops; returns its exit
    code. Raises `ViewerUnavailable` for a native viewer without a display,
    FileNotFoundError for a missing file."""
    if not Path(path).is_file():
        raise FileNotFoundError(f"no such recording: {path}")
    with open(path, "rb") as file:
        if file.read(len(RRD_MAGIC)) != RRD_MAGIC:
            raise ValueError(f"{path} is not a Rerun recording (an .rrd file of lwrl train --rrd)")
    if not web and not has_display():
        raise ViewerUnavailable("no display: use web=True (`lwrl view --web`) and open the "
                                "printed http://127.0.0.1 address, or copy the .rrd elsewhere")
    return _run(view_command(path, web, web_port, grpc_port)).returncode


def screenshot_command(png, window_size: str = "1280x800", grpc_port: int | None = None) -> list:
    """The headless render of an .rrd read from standard input to a PNG:
    `rerun - --headless --screenshot-to PNG --window-size WxH --bind 127.0.0.1 --port P
    < FILE.rrd` (a software renderer does: Mesa's lavapipe, Debian's mesa-vulkan-drivers).

    From standard input the viewer has the whole recording before the screenshot; given
    the file's path it loads it lazily (through its local catalog) and the screenshot,
    taken about a second after start, shows the plots still empty."""
    port = free_port() if grpc_port is None else grpc_port
    return [rerun_binary(), "-", "--headless", "--screenshot-to", str(png),
            "--window-size", window_size, "--bind", BIND, "--port", str(port)]


def screenshot(path, png, window_size: str = "1280x800", timeout: float = 180.0) -> Path:
    """Render a saved .rrd headless to `png` (2x `window_size` in pixels): its first screen,
    as its blueprint lays it out with no click (a recording of `lwrl train` replaying its
    last logged episode, at whichever of its steps the screenshot falls on). Raises
    `ViewerUnavailable` with the viewer's output when nothing was written."""
    png = Path(png).resolve()
    if png.exists():
        png.unlink()
    with open(path, "rb") as source:
        result = subprocess.run(screenshot_command(png, window_size), stdin=source,
                                capture_output=True, text=True, timeout=timeout,
                                env={**os.environ, "RERUN_APP_ONLY": "true"})
    if result.returncode != 0 or not png.exists():
        raise ViewerUnavailable(f"headless render failed (exit {result.returncode}):\n"
                                f"{(result.stderr or result.stdout)[-2000:]}")
    return png


@contextlib.contextmanager
def headless_viewer(window_size: str = "1280x800", timeout: float = 30.0):
    """A headless viewer (no window; a software renderer does) listening on 127.0.0.1 at a
    free port, and a `rerun.experimental.ViewerClient` connected to it, which opens
    recordings by path as a user does (`open`), reports the time cursor (`get_state`),
    moves it (`set_time`) and takes pictures of the screen or of one view
    (`take_screenshot`). The viewer stops when the block ends. Raises `ViewerUnavailable`
    when it does not listen within `timeout` seconds."""
    from rerun.experimental import ViewerClient

    port = free_port()
    log = tempfile.TemporaryFile()  # the viewer's messages (a pipe nobody reads would fill)
    process = subprocess.Popen(
        [rerun_binary(), "--headless", "--window-size", window_size, "--bind", BIND,
         "--port", str(port), "--hide-welcome-screen"],
        stdin=subprocess.DEVNULL, stdout=log, stderr=log,
        env={**os.environ, "RERUN_APP_ONLY": "true"})
    try:
        deadline = time.monotonic() + timeout
        while True:
            try:
                socket.create_connection((BIND, port), timeout=0.2).close()
                break
            except OSError:
                if process.poll() is not None or time.monotonic() > deadline:
                    process.kill()
                    process.wait()
                    log.seek(0)
                    raise ViewerUnavailable("the headless viewer did not start: "
                                            f"{log.read().decode(errors='replace')[-2000:]}") from None
                time.sleep(0.1)
        yield ViewerClient.connect(f"rerun+http://{BIND}:{port}/proxy")
    finally:
        process.terminate()
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        log.close()


__all__ = [
    "APPLICATION_ID", "BIND", "WEB_PORT", "ViewerUnavailable", "blueprint", "close_recording",
    "free_port", "headless_viewer", "load_model", "log_episode", "log_learning_curves",
    "log_task_scene", "log_value_function", "open_recording", "screenshot", "send_blueprint",
    "spawn_viewer", "view", "view_command", "web_viewer_url",
]
