"""Files appear whole or not at all."""

import os

import pytest

from hapticfx.atomic import atomic_path
from hapticfx.errors import HapticfxError


def test_success_moves_into_place_with_normal_mode(tmp_path):
    target = tmp_path / "out.bin"
    with atomic_path(target) as tmp:
        tmp.write_bytes(b"whole")
        assert not target.exists()
    assert target.read_bytes() == b"whole"
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask
    assert list(tmp_path.iterdir()) == [target]


def test_failure_leaves_nothing_and_keeps_the_old_file(tmp_path):
    target = tmp_path / "out.bin"
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_bytes(b"half")
            raise RuntimeError("interrupted")
    assert target.read_bytes() == b"old"
    assert list(tmp_path.iterdir()) == [target]


def test_missing_directory_and_directory_target(tmp_path):
    with pytest.raises(HapticfxError, match="directory does not exist"):
        with atomic_path(tmp_path / "no" / "x.bin"):
            pass
    with pytest.raises(HapticfxError, match="is a directory"):
        with atomic_path(tmp_path):
            pass
    with atomic_path(tmp_path / "made" / "x.bin", make_parents=True) as tmp:
        tmp.write_bytes(b"ok")
    assert (tmp_path / "made" / "x.bin").read_bytes() == b"ok"
