"""One peer run: the case sheet handed to the peer's worker in its own interpreter, the
trajectory file it writes, the run's CPU time as the worker measured it.

A peer is declared by a :class:`Peer` value (its code, method, interpreter, worker script,
install command and the steps it runs a case at by default); :func:`run_peer` is the one
way to run any of them.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from daebench.core.params import ParamError
from daebench.core.scene import Scene
from daebench.harness.files import ensure_writable_dir, results_dir
from daebench.workflows.export import case_sheet

WORKERS = Path(__file__).resolve().parent / "workers"
#: wall-time cap of one peer run [s] (a hung peer process is ended, never waited on for ever)
RUN_CAP_S = 600.0
#: the worker's exit code for a case or method it does not run
REFUSED_EXIT = 3


class PeerRefused(ParamError):
    """The peer does not run this case, step or method (the message says what it does)."""


class PeerFailed(RuntimeError):
    """The peer's process failed or ran past :data:`RUN_CAP_S` (its stderr's tail said)."""


class PeerUnavailable(PeerRefused):
    """The peer code is not installed where its adapter looks (the message names the install
    command)."""


@dataclass(frozen=True)
class Peer:
    """A peer code and method as `daebench peer --code NAME` runs it.

    ``interpreter()`` gives the Python that has the code (None: not found), ``probe`` the
    module it must import, ``worker`` the script run there with ``method``;
    ``default_steps`` the fixed steps [s] it runs a case at when none are given (by case name)."""

    name: str
    code: str
    method: str
    worker: str
    probe: str
    install: str
    interpreter: Callable[[], str | None]
    default_steps: Mapping[str, tuple[float, ...]] = field(default_factory=dict)
    options: Mapping[str, Any] = field(default_factory=dict)

    def python(self) -> str:
        """The interpreter that imports the peer code; :class:`PeerUnavailable` otherwise."""
        exe = self.interpreter()
        if exe is None or not importable(exe, self.probe):
            raise PeerUnavailable(f"peer '{self.name}' needs {self.code} (`import {self.probe}` in "
                                  f"{exe or 'its Python'}), which is not installed; install it with "
                                  f"`{self.install}`")
        return exe

    def steps_for(self, scene: Scene) -> tuple[float, ...]:
        if scene.name not in self.default_steps:
            raise PeerRefused(f"peer '{self.name}' has no default steps for case '{scene.name}'; give --steps "
                              f"(it declares {', '.join(self.default_steps) or 'none'})")
        return self.default_steps[scene.name]


_IMPORTABLE: dict[tuple[str, str], bool] = {}


def importable(exe: str, module: str) -> bool:
    """Whether ``exe -c 'import module'`` succeeds (asked once per process)."""
    key = (exe, module)
    if key not in _IMPORTABLE:
        try:
            r = subprocess.run([exe, "-c", f"import {module}"], capture_output=True, timeout=120)
            _IMPORTABLE[key] = r.returncode == 0
        except (OSError, subprocess.SubprocessError):
            _IMPORTABLE[key] = False
    return _IMPORTABLE[key]


def system_python() -> str | None:
    """The system's Python 3 (Debian's packages install there): DAEBENCH_SYSTEM_PYTHON,
    else /usr/bin/python3."""
    exe = os.environ.get("DAEBENCH_SYSTEM_PYTHON", "/usr/bin/python3")
    return exe if shutil.which(exe) else None


def this_python() -> str:
    """The interpreter daebench runs in."""
    return sys.executable


@dataclass(frozen=True)
class PeerRun:
    """What one peer run wrote and measured: the trajectory file, its impacts file (None for
    a case without contacts), the CPU time of the peer's run in its process [s], its steps,
    the code and method as the worker states them, and the step h [s]."""

    peer: str
    h: float
    file: Path
    impacts: Path | None
    cpu_s: float
    steps: int
    code: str
    method: str


def default_folder(scene: Scene) -> Path:
    """results/peers/<case>-<hash8>"""
    return results_dir() / "peers" / f"{scene.name}-{scene.hash[:8]}"


def check_step(h: float | str) -> float:
    """A peer's fixed step as a float; :class:`PeerRefused` for anything but a positive finite number."""
    try:
        h = float(h)
    except (TypeError, ValueError):
        raise PeerRefused(f"a peer's step must be a number, got {h!r}") from None
    if not (math.isfinite(h) and h > 0.0):
        raise PeerRefused(f"a peer's step must be positive and finite, got {h!r}")
    return h


def run_peer(peer: Peer, scene: Scene, steps: Sequence[float], out: str | Path | None = None,
             sheet: dict[str, Any] | None = None) -> list[PeerRun]:
    """``peer`` on ``scene`` at each fixed step of ``steps`` [s], one process per run, files
    in ``out`` (default :func:`default_folder`) named ``<peer>-h<h>.csv``.

    Raises
    ------
    PeerUnavailable
        The peer code is not installed (the message names the install command).
    PeerRefused
        The peer does not run this case or step (its worker's message).
    PeerFailed
        The peer's process failed (its stderr's tail) or ran past :data:`RUN_CAP_S`.
    """
    hs = [check_step(h) for h in steps]
    if not hs:
        raise PeerRefused(f"peer '{peer.name}': no steps given")
    exe = peer.python()
    folder = ensure_writable_dir(Path(out) if out is not None else default_folder(scene), "peer output folder")
    sheet = sheet if sheet is not None else case_sheet(scene)
    return [_one(peer, exe, sheet, h, folder) for h in hs]


def _one(peer: Peer, exe: str, sheet: dict[str, Any], h: float, folder: Path) -> PeerRun:
    path = folder / f"{peer.name}-h{h:.6g}.csv"
    req = {"sheet": sheet, "method": peer.method, "h": h, "csv": str(path), "label": peer.name, **peer.options}
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"} if exe != sys.executable else None
    try:
        r = subprocess.run([exe, str(WORKERS / peer.worker)], input=json.dumps(req), capture_output=True, text=True,
                           timeout=RUN_CAP_S, env=env)
    except subprocess.TimeoutExpired as exc:
        raise PeerFailed(f"peer '{peer.name}' at h = {h:g} s ran past {RUN_CAP_S:g} s and was ended") from exc
    if r.returncode == REFUSED_EXIT:
        raise PeerRefused(f"peer '{peer.name}': {r.stderr.strip()}")
    if r.returncode != 0:
        tail = "\n".join(r.stderr.strip().splitlines()[-8:])
        raise PeerFailed(f"peer '{peer.name}' at h = {h:g} s failed (exit {r.returncode}):\n{tail}")
    res = json.loads(r.stdout.strip().splitlines()[-1])
    cpu = float(res["cpu_s"])
    if not math.isfinite(cpu) or cpu < 0.0:
        raise PeerFailed(f"peer '{peer.name}' reported a CPU time of {cpu!r} s")
    imp = Path(res["impacts_file"]) if res.get("impacts_file") else None
    return PeerRun(peer.name, h, path, imp, cpu, int(res["steps"]), res["code"], res["method"])
