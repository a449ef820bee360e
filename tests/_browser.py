"""The headless browser the report-page test drives: found on PATH, or installed from the
system's packages when the test session may (root with apt-get: Debian's ``chromium``), so
that the README's test command passes on a fresh machine with no manual step. Anything
else fails with what to install — the browser test never skips."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import _apt

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
PACKAGE = "chromium"                  # Debian's package of the browser


def find(path: str | None = None) -> str | None:
    """The first of :data:`BROWSERS` on ``path`` (default: $PATH), or None."""
    for b in BROWSERS:
        found = shutil.which(b, path=path)
        if found:
            return found
    return None


def ensure(path: str | None = None, lock: Path | None = None) -> str:
    """The browser's executable: found on ``path``, else installed with apt-get (update,
    then ``install -y chromium``; :func:`_apt.ensure`). Raises AssertionError saying what to
    do when neither works."""
    return _apt.ensure(PACKAGE, lambda: find(path), f"no Chromium on PATH ({', '.join(BROWSERS)})",
                       "the browser the report-page test needs",
                       lock or Path(tempfile.gettempdir()) / "daebench-browser-install.lock", path)
