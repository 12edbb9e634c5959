"""The held-out evaluation sets: shipped specs are the recorded draws, seeds reserved, grids as drawn."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import yaml

from hapticfx.droprig.draws import RANGES, check_pretraining_seed, draw_spec, velocity_grid
from hapticfx.droprig.spec import load_spec
from hapticfx.errors import DatasetError
from hapticfx.evaluation import heldout


@pytest.mark.parametrize("name", list(heldout.HELDOUT))
def test_shipped_specs_are_the_recorded_draws_and_load(name):
    args = dict(heldout.HELDOUT[name])
    drawn = draw_spec(args.pop("draw_seed"), name=name, sim_seed=args.pop("sim_seed"), **args)
    assert yaml.safe_load(heldout.spec_path(name).read_text()) == drawn
    spec = load_spec(heldout.spec_path(name))
    assert spec.seed in range(2_610_000, 2_611_000) and len(spec.objects) >= 3


def test_the_sets_cover_three_drops_and_irregular_spacing():
    specs = {n: load_spec(heldout.spec_path(n)) for n in heldout.HELDOUT}
    assert specs["heldout-3drops"].drops == 3
    gaps = [np.diff(v) for v in specs["heldout-irregular"].velocities.values()]
    assert all(g.min() >= RANGES["irregular_min_gap_mps"] - 1e-3 for g in gaps)
    assert any(g.max() > 2 * g.min() for g in gaps)  # not an even grid


def test_velocity_grids():
    rng = np.random.default_rng(0)
    even = velocity_grid(rng, "even", 5, 2.0, 4.0)
    assert np.allclose(even, [2.0, 2.5, 3.0, 3.5, 4.0])
    h = np.square(velocity_grid(rng, "even-height", 4, 2.0, 5.0))
    assert np.allclose(np.diff(h), np.diff(h)[0], rtol=1e-2)
    with pytest.raises(DatasetError, match="cannot keep a gap"):
        velocity_grid(rng, "irregular", 20, 2.0, 3.0)


def test_reserved_seeds_are_refused_for_pretraining():
    assert check_pretraining_seed(7) == 7
    for seed in (2_600_001, 2_610_999):
        with pytest.raises(DatasetError, match="reserved for the held-out"):
            check_pretraining_seed(seed)


def test_unknown_heldout_set_is_one_clear_error(tmp_path):
    r = subprocess.run([sys.executable, "-m", "hapticfx", "data", "synth", "--heldout", "nope"],
                       capture_output=True, text=True, env={**os.environ, "HAPTICFX_CACHE": str(tmp_path)})
    assert r.returncode == 2 and "no held-out set 'nope'; known: heldout-irregular" in r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "datasets").exists()  # no set begun


def test_a_heldout_set_is_simulated_once_into_the_cache_keyed_by_its_spec(tmp_path, monkeypatch):
    spec = tmp_path / "specs" / "tiny.yaml"
    spec.parent.mkdir()
    spec.write_text("name: tiny\nseed: 5\ndrops: 2\nobjects:\n  - {id: cube, mass_kg: 0.1, dimensions_mm: [40, 40, 40],"
                    " material: wood, velocities_mps: [2.0, 3.0, 4.0]}\n")
    monkeypatch.setattr(heldout, "SPEC_DIR", spec.parent)
    monkeypatch.setattr(heldout, "HELDOUT", {"tiny": {}})
    monkeypatch.setenv("HAPTICFX_CACHE", str(tmp_path / "cache"))
    said = []
    path = heldout.ensure("tiny", workers=1, progress=said.append)
    assert path == heldout.dataset_path("tiny") and path.parent == tmp_path / "cache" / "datasets"
    assert (path / "dataset.json").is_file() and any("first use" in m for m in said)
    stamp = (path / "dataset.json").stat().st_mtime_ns
    assert heldout.resolve("heldout:tiny") == str(path) and (path / "dataset.json").stat().st_mtime_ns == stamp
    assert heldout.resolve("builtin:helmet-drops") == "builtin:helmet-drops"
    spec.write_text(spec.read_text().replace("seed: 5", "seed: 6"))
    assert heldout.dataset_path("tiny") != path  # an edited spec never reuses the old set


def test_data_draw_writes_specs_synth_reads_and_refuses_reserved_seeds(tmp_path):
    out = tmp_path / "rigs"
    r = subprocess.run([sys.executable, "-m", "hapticfx", "data", "draw", "2700015", "2700016", "--drops", "3",
                        "--spacing", "irregular", "--out", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    for seed in (2700015, 2700016):
        path = out / f"draw-{seed}.yaml"
        assert path.name in r.stdout
        written = yaml.safe_load(path.read_text())
        assert written == draw_spec(seed, name=f"draw-{seed}", sim_seed=seed + 10_000, drops=3, spacing="irregular")
        spec = load_spec(path)  # what `data synth --spec` reads
        assert spec.drops == 3 and spec.seed == seed + 10_000
    # one reserved seed (or a seed whose simulation seed is reserved): nothing written, one line, exit 2
    for bad in ("2600002", "2600500"):
        r = subprocess.run([sys.executable, "-m", "hapticfx", "data", "draw", "7", bad, "--out", str(tmp_path / "no")],
                           capture_output=True, text=True)
        assert r.returncode == 2 and "reserved for the held-out evaluation sets" in r.stderr
        assert "Traceback" not in r.stderr and not (tmp_path / "no").exists()


def test_data_draw_refuses_a_negative_seed_an_edited_spec_and_a_file_for_its_folder(tmp_path, capsys):
    from hapticfx.cli import main

    def draw(*argv):
        with pytest.raises(SystemExit) as exit_:
            main(["data", "draw", *map(str, argv)])
        return exit_.value.code, capsys.readouterr().err

    code, err = draw("--out", tmp_path / "d", "--", -5)
    assert code == 2 and "-5 is not in the range 0<=x<=" in err and not (tmp_path / "d").exists()
    spec = tmp_path / "d" / "draw-5.yaml"
    for _ in range(2):  # the same draw again replaces its own file
        assert draw(5, "--out", tmp_path / "d") == (0, "")
    spec.write_text(spec.read_text() + "# my edit\n")
    for argv in ((5,), (5, "--drops", 4)):
        code, err = draw(*argv, "--out", tmp_path / "d")
        assert code == 2 and err.count("\n") == 1 and f"{spec}: exists and is not this draw" in err
        assert spec.read_text().endswith("# my edit\n")
    assert draw(5, "--drops", 4, "--out", tmp_path / "d", "--force") == (0, "")
    assert load_spec(spec).drops == 4
    (tmp_path / "afile").write_text("x")
    for out in (tmp_path / "afile", tmp_path / "afile" / "sub"):
        code, err = draw(5, "--out", out)
        assert code == 2 and err == f"hapticfx: error: {tmp_path / 'afile'}: not a folder\n"
