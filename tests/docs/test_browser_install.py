"""The report-page test's browser (tests._browser): found on PATH, else installed with
apt-get when the session runs as root (once, update then install), else a failure that
says what to install. apt-get here is a stand-in script, alone on a PATH of its own, that
records its arguments and, on install, puts an executable ``chromium`` on that PATH."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

import _browser as browser


def _fake_apt(tmp: Path, fail_install: bool = False) -> tuple[str, Path]:
    bin_ = tmp / "bin"
    bin_.mkdir()
    log = tmp / "apt.log"
    chromium = bin_ / "chromium"
    install = ("echo 'E: Unable to locate package chromium' >&2; exit 100" if fail_install else
               f"printf '#!/bin/sh\\necho headless\\n' > {chromium}; /bin/chmod +x {chromium}")
    script = bin_ / "apt-get"
    script.write_text(f"#!/bin/sh\necho \"$DEBIAN_FRONTEND $*\" >> {log}\n"
                      f"case \"$1\" in install) {install};; esac\n")
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    return str(bin_), log   # the stand-in PATH: nothing else on it (the scripts call sh builtins and /bin/chmod)


def test_found_on_path_is_used_without_installing(tmp_path):
    path, log = _fake_apt(tmp_path)
    (tmp_path / "bin" / "google-chrome").write_text("#!/bin/sh\n")
    (tmp_path / "bin" / "google-chrome").chmod(0o755)
    assert browser.ensure(path, lock=tmp_path / "lock") == str(tmp_path / "bin" / "google-chrome")
    assert not log.exists()


def test_missing_browser_is_installed_as_root(tmp_path, monkeypatch):
    path, log = _fake_apt(tmp_path)
    monkeypatch.setattr(os, "geteuid", lambda: 0)
    got = browser.ensure(path, lock=tmp_path / "lock")
    assert got == str(tmp_path / "bin" / "chromium")
    assert log.read_text().splitlines() == ["noninteractive update -qq", "noninteractive install -y -qq chromium"]
    # a second call finds it: no second install
    assert browser.ensure(path, lock=tmp_path / "lock") == got
    assert len(log.read_text().splitlines()) == 2


def test_not_root_fails_saying_what_to_install(tmp_path, monkeypatch):
    path, log = _fake_apt(tmp_path)
    monkeypatch.setattr(os, "geteuid", lambda: 1000)
    with pytest.raises(AssertionError, match=r"not run as root.*apt-get install -y chromium"):
        browser.ensure(path, lock=tmp_path / "lock")
    assert not log.exists()


def test_failed_install_says_why(tmp_path, monkeypatch):
    path, _ = _fake_apt(tmp_path, fail_install=True)
    monkeypatch.setattr(os, "geteuid", lambda: 0)
    with pytest.raises(AssertionError, match=r"(?s)apt-get install -y -qq chromium.*exit 100.*Unable to locate"):
        browser.ensure(path, lock=tmp_path / "lock")
