"""The headless browser the report-page test drives: found on PATH, or installed from the
system's packages when the test session may (root with apt-get: Debian's ``chromium``), so
that the README's test command passes on a fresh machine with no manual step. Anything
else fails with what to install — the browser test never skips."""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
PACKAGE = "chromium"                  # Debian's package of the browser
INSTALL_TIMEOUT_S = 1200.0            # a fresh machine downloads ~100 MB


def find(path: str | None = None) -> str | None:
    """The first of :data:`BROWSERS` on ``path`` (default: $PATH), or None."""
    for b in BROWSERS:
        found = shutil.which(b, path=path)
        if found:
            return found
    return None


def _can_install(path: str | None) -> str | None:
    """Why this process cannot install the package itself (None: it can)."""
    if shutil.which("apt-get", path=path) is None:
        return "there is no apt-get on PATH (not a Debian-like system)"
    if os.geteuid() != 0:
        return "the tests do not run as root (apt-get needs it)"
    return None


def ensure(path: str | None = None, lock: Path | None = None) -> str:
    """The browser's executable: found on ``path``, else installed with apt-get (update,
    then ``install -y chromium``; one process at a time under a file lock, so parallel test
    workers install it once). Raises AssertionError saying what to do when neither works."""
    found = find(path)
    if found:
        return found
    why = _can_install(path)
    if why:
        raise AssertionError(f"no Chromium on PATH ({', '.join(BROWSERS)}) and {why}: install it, e.g. "
                             f"`sudo apt-get install -y {PACKAGE}` on Debian/Ubuntu, then run the tests again")
    lock = lock or Path(tempfile.gettempdir()) / "daebench-browser-install.lock"
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    if path is not None:
        env["PATH"] = path
    apt = shutil.which("apt-get", path=path)
    with open(lock, "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)       # another worker may be installing it now
        found = find(path)
        if found:
            return found
        for args in (["update", "-qq"], ["install", "-y", "-qq", PACKAGE]):
            p = subprocess.run([apt, *args], env=env, capture_output=True, text=True, timeout=INSTALL_TIMEOUT_S)
            if p.returncode != 0:
                raise AssertionError(f"`apt-get {' '.join(args)}` failed (exit {p.returncode}) while installing "
                                     f"the browser the report-page test needs:\n{(p.stderr or p.stdout)[-1500:]}")
    found = find(path)
    if not found:
        raise AssertionError(f"`apt-get install {PACKAGE}` succeeded but none of {', '.join(BROWSERS)} is on PATH")
    return found
