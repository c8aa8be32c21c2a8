"""Progress on long work: on a terminal a ticking line after two seconds, nothing when the
output is not a terminal or with cosim --quiet (TQDM_DISABLE)."""
import fcntl
import os
import pty
import struct
import subprocess
import sys
import termios
import time

CHILD = "import time\nfrom cosim.cli import working\nwith working('crunching'):\n    time.sleep(2.8)\nprint('done')\n"


def _run_on_a_terminal(env_extra=None):
    main, sub = pty.openpty()
    fcntl.ioctl(sub, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
    env = {**os.environ, **(env_extra or {})}
    env.pop("TQDM_DISABLE", None) if not env_extra else None
    p = subprocess.Popen([sys.executable, "-c", CHILD], stdin=sub, stdout=sub, stderr=sub, env=env)
    os.close(sub)
    out = b""
    t0 = time.time()
    while time.time() - t0 < 30:
        try:
            chunk = os.read(main, 4096)
        except OSError:
            break
        if not chunk:
            break
        out += chunk
    p.wait(timeout=30)
    os.close(main)
    return out.decode(errors="replace")


def test_a_ticking_line_on_a_terminal_and_none_when_quiet():
    out = _run_on_a_terminal()
    assert "crunching: 00:0" in out and "done" in out, out
    quiet = _run_on_a_terminal({"TQDM_DISABLE": "1"})
    assert "crunching" not in quiet and "done" in quiet, quiet


def test_nothing_when_not_a_terminal():
    p = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, timeout=30)
    assert p.returncode == 0 and "crunching" not in p.stderr + p.stdout
