"""What a test needs from the system's packages, found or installed: installed with apt-get
(update, then ``install -y``) when the test session may — root, with apt-get on PATH — one
process at a time under a file lock, so that parallel workers install it once; anything else
fails saying what to install. The README's test command then passes on a fresh machine with
no manual step (tests/_browser.py: Chromium; tests/_peers.py: Siconos)."""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Callable, TypeVar

INSTALL_TIMEOUT_S = 1200.0            # a fresh machine downloads ~100 MB
T = TypeVar("T")


def can_install(path: str | None = None) -> str | None:
    """Why this process cannot install a package itself (None: it can)."""
    if shutil.which("apt-get", path=path) is None:
        return "there is no apt-get on PATH (not a Debian-like system)"
    if os.geteuid() != 0:
        return "the tests do not run as root (apt-get needs it)"
    return None


def ensure(package: str, present: Callable[[], T | None], missing: str, what: str,
           lock: Path | None = None, path: str | None = None) -> T:
    """``present()`` (not None: what is there), after installing Debian's ``package`` when it
    is None. ``missing``: the sentence that says what is not there; ``what``: what needs it.
    Raises AssertionError saying what to do when it can be neither found nor installed."""
    found = present()
    if found is not None:
        return found
    why = can_install(path)
    if why:
        raise AssertionError(f"{missing} and {why}: install it, e.g. `sudo apt-get install -y {package}` on "
                             f"Debian/Ubuntu, then run the tests again")
    lock = lock or Path(tempfile.gettempdir()) / f"daebench-{package}-install.lock"
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    if path is not None:
        env["PATH"] = path
    apt = shutil.which("apt-get", path=path)
    with open(lock, "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)       # another worker may be installing it now
        found = present()
        if found is not None:
            return found
        for args in (["update", "-qq"], ["install", "-y", "-qq", package]):
            p = subprocess.run([apt, *args], env=env, capture_output=True, text=True, timeout=INSTALL_TIMEOUT_S)
            if p.returncode != 0:
                raise AssertionError(f"`apt-get {' '.join(args)}` failed (exit {p.returncode}) while installing "
                                     f"{what}:\n{(p.stderr or p.stdout)[-1500:]}")
    found = present()
    if found is None:
        raise AssertionError(f"`apt-get install {package}` succeeded but {missing[0].lower() + missing[1:]}")
    return found
