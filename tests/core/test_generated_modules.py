"""No executable cache: a generated kernel module runs the text the code generates, never a
planted or truncated file, and a kernel folder others can write is passed over."""

from __future__ import annotations

from pathlib import Path


def _handle_module(name: str = "pendulum"):
    from daebench.api import load_scene
    from daebench.core import handles
    from daebench.models import build_system

    md = build_system(load_scene(name)).kernel_data()
    for k in [k for k in handles._MODULES if k[0] is type(md)]:
        handles._MODULES.pop(k)
    handles.handle(md)
    made = [k for k in handles._MODULES if k[0] is type(md)]
    assert len(made) == 1
    return md, Path(handles._MODULES[made[0]].__file__), made


def test_a_line_planted_in_a_generated_kernel_module_does_not_run(tmp_path):
    """A line appended to a module under daebench-handles/ ran on the next run: what runs is
    the text daebench generates, and the file is written anew when it differs."""
    from daebench.core import handles

    md, path, made = _handle_module()
    good = path.read_bytes()
    marker = tmp_path / "planted"
    path.write_bytes(good + f"\nopen({str(marker)!r}, 'w').write('ran')\nraise SystemExit('planted')\n".encode())
    for k in made:
        handles._MODULES.pop(k)
    h = handles.handle(md)
    assert not marker.exists() and path.read_bytes() == good
    assert h.fns.shape == (len(handles.SIGNATURES),) and (h.fns != 0).all()


def test_a_truncated_generated_kernel_module_is_regenerated():
    """A truncated module broke every later run ('a bug in integrator hht') and was never repaired."""
    from daebench.core import handles

    md, path, made = _handle_module()
    good = path.read_bytes()
    path.write_bytes(good[: len(good) // 2])
    for k in made:
        handles._MODULES.pop(k)
    handles.handle(md)
    assert path.read_bytes() == good


def test_a_kernel_folder_others_can_write_is_passed_over(tmp_path, monkeypatch):
    """With no writable home cache the fallback was a shared /tmp/daebench-numba/ whose .py files
    were imported with no owner or permission check."""
    import os

    import numba

    from daebench.core import handles

    shared = tmp_path / "shared"
    (shared / "daebench-handles").mkdir(parents=True)
    os.chmod(shared / "daebench-handles", 0o777)
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(shared))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "home-cache"))
    d = handles._directory()
    assert d == tmp_path / "home-cache" / "daebench" / "daebench-handles"
    assert not os.stat(d).st_mode & 0o022
