"""The entry-point list kept in the user cache: the same as importlib.metadata's, and never stale."""

import json
import os
import shutil
import subprocess
import sys
from importlib import metadata

import pytest
from hfx_testdata import actuator_plugin, fake_distribution

from hapticfx import entrypoints
from hapticfx.registry import get_registry, reset_registry

PLUGIN = actuator_plugin("Tick", "tick")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("HAPTICFX_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("HAPTICFX_PLUGINS", raising=False)
    yield tmp_path / "cache" / entrypoints.CACHE_NAME
    reset_registry()
    sys.modules.pop("hfx_tick", None)


@pytest.fixture
def site(tmp_path, monkeypatch):
    folder = tmp_path / "site"
    folder.mkdir()
    fake_distribution(folder, dist="hfx-tick", version="2.0", entry_point="tick", module="hfx_tick", source=PLUGIN)
    monkeypatch.syspath_prepend(str(folder))
    return folder


def _from_metadata():
    return [(ep.name, ep.value, ep.dist.name, ep.dist.version) for ep in metadata.entry_points(group="hapticfx")]


def test_kept_list_is_what_importlib_metadata_finds(cache, site):
    first = entrypoints.installed()
    assert cache.is_file()
    again = entrypoints.installed()  # read back from the file
    assert again == first
    assert [(e.name, e.value, e.distribution, e.version) for e in again.entry_points] == _from_metadata()
    assert again.hapticfx_version == metadata.version("hapticfx")
    assert ("tick", "hfx_tick", "hfx-tick", "2.0") in _from_metadata()


def test_a_warm_start_does_not_import_importlib_metadata(tmp_path):
    code = ("import sys; from hapticfx.registry import get_registry; r = get_registry(); "
            "print('importlib.metadata' in sys.modules, r.get('actuator', 'vibro-transducer').distribution)")
    env = {**os.environ, "HAPTICFX_CACHE": str(tmp_path)}
    runs = [subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
            for _ in range(2)]
    assert runs == ["True hapticfx-soundcard\n", "False hapticfx-soundcard\n"]


def test_a_plugin_installed_edited_and_removed_is_seen_at_once(cache, tmp_path, monkeypatch):
    reset_registry()
    assert "tick" not in get_registry().names("actuator")  # warms the cache without the plugin
    folder = tmp_path / "later"
    folder.mkdir()
    monkeypatch.syspath_prepend(str(folder))
    reset_registry()
    assert "tick" not in get_registry().names("actuator")  # a new, empty folder on sys.path
    fake_distribution(folder, dist="hfx-tick", version="2.0", entry_point="tick", module="hfx_tick", source=PLUGIN)
    reset_registry()
    assert get_registry().get("actuator", "tick").version == "2.0"  # installed into a folder already read
    info = folder / "hfx_tick-2.0.dist-info" / "entry_points.txt"
    stamp = os.stat(info)
    info.write_text("[hapticfx]\ntock = hfx_tick\n")  # edited in place: the same size, a new time
    os.utime(info, ns=(stamp.st_atime_ns, stamp.st_mtime_ns + 1))
    reset_registry()
    assert get_registry().get("actuator", "tick").plugin == "tock"
    info.write_text("[hapticfx]\ntocker = hfx_tick\n")  # another size, the time set back
    os.utime(info, ns=(stamp.st_atime_ns, stamp.st_mtime_ns + 1))
    reset_registry()
    assert get_registry().get("actuator", "tick").plugin == "tocker"
    shutil.rmtree(folder / "hfx_tick-2.0.dist-info")
    reset_registry()
    assert "tick" not in get_registry().names("actuator")


@pytest.mark.parametrize("damage", ["{not json", "", "[1, 2]", '{"kept": 3}', "no entry points"])
def test_a_damaged_cache_is_read_again_from_the_metadata(cache, site, damage):
    entrypoints.installed()
    mark = json.loads(cache.read_text())["kept"][0]["fingerprint"]
    cache.write_text(json.dumps({"kept": [{"fingerprint": mark, "hapticfx_version": "1"}]})
                     if damage == "no entry points" else damage)
    assert [e.name for e in entrypoints.installed().entry_points] == [ep[0] for ep in _from_metadata()]
    assert len(json.loads(cache.read_text())["kept"][0]["entry_points"]) == len(_from_metadata())  # whole again


def test_each_way_of_starting_keeps_its_own_list(cache, tmp_path, monkeypatch):
    """A console script and `python -m hapticfx` in a source tree see different sys.paths: neither evicts the other."""
    ways = []
    for k in range(entrypoints.KEPT + 1):
        (tmp_path / f"way{k}" / f"x{k}-1.0.dist-info").mkdir(parents=True)  # a distribution without entry points
        ways.append(tmp_path / f"way{k}")
    base = list(sys.path)
    scans = []
    scan = entrypoints._scan
    monkeypatch.setattr(entrypoints, "_scan", lambda: scans.append(1) or scan())

    def start(k):
        monkeypatch.setattr(sys, "path", [str(ways[k]), *base])
        return entrypoints.installed()

    for k in range(entrypoints.KEPT):
        start(k)
    assert len(scans) == entrypoints.KEPT
    for k in (0, 3, 1, 2, 0):
        start(k)
    assert len(scans) == entrypoints.KEPT  # every one kept
    start(entrypoints.KEPT)  # one more: the least recently used, 3, makes room
    for k in (0, 1, 2, entrypoints.KEPT):
        start(k)
    assert len(scans) == entrypoints.KEPT + 1
    start(3)
    assert len(scans) == entrypoints.KEPT + 2


def test_an_unwritable_cache_folder_only_costs_time(tmp_path, monkeypatch, site):
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("HAPTICFX_CACHE", str(tmp_path / "file" / "cache"))  # a folder cannot be made there
    reset_registry()
    assert get_registry().get("actuator", "tick").distribution == "hfx-tick"
    reset_registry()
    sys.modules.pop("hfx_tick", None)


def test_load_follows_module_and_attribute_paths():
    ep = entrypoints.EntryPoint("x", "hapticfx.registry:lazy.resolve", "d", "1")
    from hapticfx.registry import lazy
    assert ep.load() is lazy.resolve
    assert entrypoints.EntryPoint("x", "hapticfx.caches [extra]", "d", "1").load().__name__ == "hapticfx.caches"
