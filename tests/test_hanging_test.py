"""A test that hangs ends the suite's wait, not the suite: pytest-timeout, configured in
pyproject.toml ([tool.pytest.ini_options] `timeout`, `timeout_method = "thread"`), fails it
with every thread's stack printed, here with the timeout shortened to two seconds."""

import pathlib
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
HANG = """
import time

def test_hangs():
    time.sleep(600)
"""


def test_a_hanging_test_fails_with_the_stacks_of_its_threads(tmp_path):
    path = tmp_path / "test_hang.py"
    path.write_text(HANG)
    started = time.monotonic()
    ran = subprocess.run([sys.executable, "-m", "pytest", "-c", str(ROOT / "pyproject.toml"),
                          "--rootdir", str(tmp_path), "-p", "no:cacheprovider", "--timeout", "2",
                          str(path)], capture_output=True, text=True, timeout=300)
    assert time.monotonic() - started < 120
    assert ran.returncode != 0
    output = ran.stdout + ran.stderr
    assert "Stack of MainThread" in output and "time.sleep(600)" in output, output[-3000:]
