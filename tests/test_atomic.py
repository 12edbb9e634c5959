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


def test_errors_name_the_users_path_not_the_hidden_temporary(tmp_path):
    (tmp_path / "afile").write_text("x")
    target = tmp_path / "afile" / "out.bin"  # its folder is a file: the temporary cannot be made
    with pytest.raises(NotADirectoryError) as made:
        with atomic_path(target):
            pass
    assert made.value.filename == str(target)
    target = tmp_path / "out.bin"
    with pytest.raises(NotADirectoryError) as written:  # a failure in the block that names the temporary
        with atomic_path(target) as tmp:
            open(tmp / "inside", "w")
    assert written.value.filename == str(target) and list(tmp_path.iterdir()) == [tmp_path / "afile"]
    with pytest.raises(OSError) as other:  # an error about another file is left as it is
        with atomic_path(target):
            open(tmp_path / "missing" / "x")
    assert other.value.filename == str(tmp_path / "missing" / "x")


def test_a_dataset_writers_errors_name_the_dataset_folder(tmp_path):
    from hapticfx.data.dataset import DatasetWriter

    out = tmp_path / "ds"
    with pytest.raises(FileExistsError) as failed:  # raw/ is a file
        with DatasetWriter(out, name="ds", rate_hz=1000.0, n_samples=500) as writer:
            (writer.tmp / "raw").write_text("in the way")
            writer.write_raw("wood-beam", [1.0], [[[[0.0, 0.0, 1.0]]]])
    assert failed.value.filename == str(out) and list(tmp_path.iterdir()) == []
