"""The web viewer in a real browser: `lwrl view --web` serves a recording on 127.0.0.1, and
headless Chromium, driven over the DevTools protocol, shows the scene and the plots.

Chromium comes from Debian's `chromium` package (`.ci/run` installs it); without it, or where
it cannot start, the test is skipped, saying why. It renders WebGL in software (SwiftShader).
"""

import base64
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import psutil
import pytest

from lwrl.runners.config import RunConfig
from lwrl.viz import scenes
from lwrl.viz import rerun as viz

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
CHROMIUM_FLAGS = (
    "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
    "--disable-quic", "--no-first-run", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--window-size=1280,800",
    "--remote-debugging-pipe")
"""Headless, software WebGL, and nothing that reaches out to the network (on a closed
network Chromium fails without the background-networking flags)."""
WAIT = 150.0
"""Seconds the page may take to load the web viewer and the recording and draw them."""


class Chromium:
    """Headless Chromium driven over the DevTools protocol on a pipe (its file descriptors 3
    and 4: JSON messages ended by a NUL byte), with a fresh profile."""

    def __init__(self, binary: str, profile):
        commands, self._to_browser = os.pipe()
        self._from_browser, replies = os.pipe()
        flags = [*CHROMIUM_FLAGS, f"--user-data-dir={profile}", "about:blank"]
        # A trampoline puts the pipe's ends on descriptors 3 and 4, where Chromium reads them.
        trampoline = (f"import os; os.dup2({commands}, 3); os.dup2({replies}, 4); "
                      f"os.execv({binary!r}, {[binary, *flags]!r})")
        self.log = os.path.join(profile, "stderr.log")
        with open(self.log, "w") as log:
            self.process = subprocess.Popen(
                [sys.executable, "-c", trampoline], pass_fds=(commands, replies),
                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=log,
                start_new_session=True)
        os.close(commands)
        os.close(replies)
        self._buffer, self._id = b"", 0

    def call(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        """Send one command; return its result (events in between are skipped)."""
        self._id += 1
        message = {"id": self._id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self._to_browser, json.dumps(message).encode() + b"\0")
        while True:
            while b"\0" not in self._buffer:
                chunk = os.read(self._from_browser, 1 << 16)
                if not chunk:
                    raise ConnectionError("Chromium closed its DevTools pipe")
                self._buffer += chunk
            raw, self._buffer = self._buffer.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]

    def open(self, url: str) -> str:
        """A new tab, attached to before it goes to `url`; returns its session."""
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        self.call("Page.enable", session=session)
        self.call("Page.navigate", {"url": url}, session)
        return session

    def screenshot(self, session: str) -> np.ndarray:
        from PIL import Image

        data = self.call("Page.captureScreenshot", {"format": "png"}, session)["data"]
        return np.asarray(Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB"))

    def close(self) -> None:
        try:
            self.call("Browser.close")
            self.process.wait(timeout=20)
        except Exception:
            pass
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait()
        os.close(self._to_browser)
        os.close(self._from_browser)


@pytest.fixture
def chromium(tmp_path):
    binary = next((found for name in BROWSERS if (found := shutil.which(name))), None)
    if binary is None:
        pytest.skip("Chromium is not installed (Debian: apt-get install chromium, as .ci/run does)")
    profile = tmp_path / "chromium-profile"
    profile.mkdir()
    browser = Chromium(binary, str(profile))
    try:
        browser.call("Browser.getVersion")
    except (ConnectionError, OSError) as error:
        browser.close()
        with open(browser.log) as log:
            pytest.skip(f"Chromium cannot run here ({error}): {log.read()[-500:]}")
    yield browser
    browser.close()


def saturated(pixels) -> int:
    """Pixels of a colour (a plotted series), not of the viewer's greys."""
    pixels = pixels.astype(int)
    return int(((pixels.max(axis=-1) - pixels.min(axis=-1)) > 40).sum())


def near(pixels, color, tolerance: float = 45.0) -> int:
    """Pixels within `tolerance` of `color` (a drawn shape's, as its domain gives it)."""
    return int((np.linalg.norm(pixels.astype(float) - np.asarray(color, float), axis=-1) < tolerance).sum())


def test_web_viewer_shows_the_scene_and_the_plots_in_chromium(chromium, tmp_path):
    """`lwrl view REC --web` prints the address to open, listens on 127.0.0.1 only, and the
    page, in headless Chromium, draws the scene (Mountain-Car's hill, in its colour) in the
    left column and the signal plots' lines in the right one (the blueprint's layout); the
    address without its `?url=` would show Rerun's welcome screen, which fails both."""
    from lwrl.cli.rerun_options import send_run
    from lwrl.runners.run import run

    config = RunConfig(task="mountain_car.cost_to_go", agents=1, episodes=3, seed=0)
    agent, results = run(config, record=[(0, 0), (0, 2)])
    path = tmp_path / "run.rrd"
    send_run(config, results, agent, rrd_path=path)
    hill = scenes.drawing_of("mountain_car").fixed["hill"].color
    server = subprocess.Popen(
        [sys.executable, "-m", "lwrl.cli", "view", str(path), "--web", "--port", str(viz.free_port())],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
        env={**os.environ, "BROWSER": "true"},  # Rerun opens $BROWSER on the address: not here
        start_new_session=True)
    try:
        line = server.stdout.readline()
        found = re.search(r"open (http://127\.0\.0\.1:\d+/\?url=\S+)", line)
        assert found, line
        url = found.group(1)
        session = chromium.open(url)
        deadline = time.monotonic() + WAIT
        while True:
            time.sleep(2)
            try:
                pixels = chromium.screenshot(session)
            except RuntimeError:  # "Not attached to an active page" while the page commits
                assert time.monotonic() < deadline, "the page never came up"
                continue
            height, width = pixels.shape[:2]
            scene = pixels[int(0.08 * height):int(0.5 * height), int(0.02 * width):int(0.38 * width)]
            plots = pixels[int(0.1 * height):int(0.9 * height), int(0.43 * width):int(0.98 * width)]
            drawn = {"scene": near(scene, hill), "plots": saturated(plots)}
            if min(drawn.values()) > 300 or time.monotonic() > deadline:
                break
        listening = [c.laddr for process in psutil.Process(server.pid).children(recursive=True)
                     for c in process.net_connections(kind="tcp") if c.status == psutil.CONN_LISTEN]
    finally:
        os.killpg(server.pid, signal.SIGTERM)
        server.wait(timeout=30)
        server.stdout.close()
    from PIL import Image

    Image.fromarray(pixels).save(tmp_path / "web_viewer.png")
    assert min(drawn.values()) > 300, f"{drawn} coloured pixels after {WAIT:g} s; see {tmp_path}/web_viewer.png"
    assert listening and all(address.ip == viz.BIND for address in listening), listening
