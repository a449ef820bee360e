"""Siconos plugins compiled from C source: the C functions a Siconos system or relation calls
(mass matrix, forces, gaps and their gradients), built once per source by the system's C++
compiler (``c++``, Debian's ``g++``) against nothing but libm into the user's cache folder
(``~/.cache/daebench/siconos-plugins/``), as Siconos' own examples build theirs. Standard
library only: it runs in the peer's interpreter."""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path


def compiled(source: str, name: str) -> Path:
    """The plugin of ``source`` (built on first use), its path without the ``.so`` suffix
    that Siconos' plugin loader adds; ``name`` heads the file's name.

    Raises
    ------
    common.Refused
        No C++ compiler on the PATH (the message names the package that installs one).
    """
    digest = hashlib.sha256(source.encode()).hexdigest()[:12]
    folder = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "daebench" / "siconos-plugins"
    stem = folder / f"{name}-{digest}"
    if not stem.with_suffix(".so").exists():
        cxx = shutil.which("c++") or shutil.which("g++")
        if cxx is None:
            import common
            raise common.Refused(f"the Siconos plugin {name} needs a C++ compiler (apt-get install g++)")
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=folder) as tmp:
            src = Path(tmp) / "plugin.cpp"
            src.write_text(source)
            so = Path(tmp) / "plugin.so"
            subprocess.run([cxx, "-O2", "-shared", "-fPIC", str(src), "-o", str(so), "-lm"], check=True,
                           capture_output=True, timeout=300)
            os.replace(so, stem.with_suffix(".so"))
    return stem
