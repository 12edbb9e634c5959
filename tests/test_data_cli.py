"""The data commands and `bench reducers` through the real CLI entry point."""

import numpy as np
import pytest

from hapticfx.cli import main
from hapticfx.data.build import build_dataset
from hapticfx.data.dataset import open_dataset
from hapticfx.data.toy import toy_recordings
from hapticfx.objects import PAPER_OBJECTS


def run(capsys, *argv):
    with pytest.raises(SystemExit) as exit_:
        main(list(map(str, argv)))
    out = capsys.readouterr()
    return exit_.value.code, out.out, out.err


@pytest.fixture
def dataset(tmp_path):
    recs = [toy_recordings(PAPER_OBJECTS[o], [2.42, 3.13, 3.96], drops=4, seed=i)
            for i, o in enumerate(("wood-beam", "steel-plate"))]
    return build_dataset(tmp_path / "ds", recs, name="cli", rate_hz=1000.0, sensor={"model": "synthetic"},
                         provenance={"source": "test"})


def test_record_import_info_plot_pick_end_to_end(tmp_path, capsys):
    pytest.importorskip("serial")
    from hapticfx.board.emulator import AccelBoardEmulator

    t = np.arange(300) / 1000.0
    imp = [np.stack([a * np.exp(-t / 0.03) * np.sin(2 * np.pi * 120 * t), 0.4 * a * np.exp(-t / 0.03) * np.sin(2 * np.pi * 200 * t),
                     np.zeros_like(t)], axis=1) for a in (2.0, 2.4, 1.8, 2.2)]
    rec = tmp_path / "rec"
    for height, impacts in ((0.3, imp[:2]), (0.6, imp[2:])):
        with AccelBoardEmulator(impacts) as emu:
            code, out, err = run(capsys, "data", "record", "--port", emu.port, "--object", "wood-beam",
                                 "--height-m", height, "--drops", 2, "--out-dir", rec, "--samples", 800)
        assert code == 0, err
        assert "v = " in err and len(out.split()) == 2
    ds_path = tmp_path / "ds"
    code, out, err = run(capsys, "data", "import", *sorted(rec.glob("*.csv")), "--out", ds_path,
                         "--sensor", "model=ADXL335", "--sensor", "board=GY-61")
    assert code == 0, err
    assert "note: fewer than 5 drops a velocity: wood-beam (2);" in err  # 2 drops a velocity: said, not refused
    ds = open_dataset(ds_path)
    assert ds.meta["sensor"] == {"model": "ADXL335", "board": "GY-61"}
    assert ds.bank("wood-beam", "max-min").velocities.tolist() == pytest.approx([np.sqrt(2 * 9.80665 * h) for h in (0.3, 0.6)])

    code, out, _ = run(capsys, "data", "info", ds_path)
    assert code == 0 and "wood-beam" in out and "(by hand)" not in out

    code, out, err = run(capsys, "data", "pick", "wood-beam", ds.bank("wood-beam", "max-min").velocities[1], 1,
                         "--dataset", ds_path)
    assert code == 0, err
    code, out, _ = run(capsys, "data", "info", ds_path)
    assert f"{ds.bank('wood-beam', 'max-min').velocities[1]:g} m/s #1 (by hand)" in out

    png = tmp_path / "fig.png"
    code, out, err = run(capsys, "data", "plot", "wood-beam", "--dataset", ds_path, "--out", png)
    assert code == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_info_notes_objects_with_fewer_than_five_drops_a_velocity(dataset, tmp_path, capsys):
    code, out, _ = run(capsys, "data", "info", dataset)
    assert code == 0 and "note: fewer than 5 drops a velocity: steel-plate (4), wood-beam (4);" in out
    recs = [toy_recordings(PAPER_OBJECTS["wood-beam"], [2.42, 3.13, 3.96], drops=5, seed=0)]
    five = build_dataset(tmp_path / "five", recs, name="five", rate_hz=1000.0, sensor={"model": "synthetic"},
                         provenance={"source": "test"})
    code, out, _ = run(capsys, "data", "info", five)
    assert code == 0 and "x 5 drops" in out and "note:" not in out


def test_bench_reducers_prints_table4_and_timings(dataset, capsys):
    code, out, err = run(capsys, "bench", "reducers", "--dataset", dataset, "--repeats", 3, "--number", 5,
                         "--samples", 20000)
    assert code == 0, err
    table = out.split("\n\n")[0]
    rows = [r for r in table.splitlines() if r.startswith("| wood-beam") or r.startswith("| steel-plate")]
    assert len(rows) == 2
    cells = rows[0].strip("|").split("|")
    assert float(cells[2]) == pytest.approx(1.0, abs=1e-3)  # DFT321 spectral vs RSS: 1 by construction
    assert 0 < float(cells[4]) < 1
    assert "max-min / DFT321" in out and "20000 samples" in out


def test_bad_input_is_one_line_exit_2(tmp_path, capsys, monkeypatch):
    bad = tmp_path / "bad.csv"
    bad.write_text("object,velocity_mps,drop,t_s,ax_g,ay_g\n")
    code, out, err = run(capsys, "data", "import", bad, "--out", tmp_path / "ds")
    assert code == 2 and err.count("\n") == 1 and "bad.csv: line 1: header must be exactly" in err
    code, _, err = run(capsys, "data", "info", tmp_path / "missing")
    assert code == 2 and "not a hapticfx dataset" in err
    code, _, err = run(capsys, "data", "plot", "wood-beam", "--dataset", tmp_path / "missing")
    assert code == 2
    monkeypatch.chdir(tmp_path)  # the default --out-dir, recordings/, is relative to where the command runs
    code, _, err = run(capsys, "data", "record", "--port", "/dev/nope", "--object", "x", "--height-m", 1)
    assert code == 2 and "cannot open serial port" in err
    assert not (tmp_path / "recordings").exists()  # a failed start writes nothing, not even the folder
    (tmp_path / "afile").write_text("x")
    code, _, err = run(capsys, "data", "record", "--port", "/dev/nope", "--object", "x", "--height-m", 1,
                       "--out-dir", tmp_path / "afile")
    assert code == 2 and err.count("\n") == 1 and "afile: not a folder" in err


def test_builtin_dataset_banks_agree_with_its_raw_drops(capsys):
    from hapticfx.data.dataset import BUILTIN_DIR
    from hapticfx.processing.reducers import dft321, max_min

    if not (BUILTIN_DIR / "helmet-drops" / "dataset.json").is_file():
        pytest.skip("builtin:helmet-drops is not generated in this checkout")
    ds = open_dataset("builtin:helmet-drops")
    obj = ds.objects[0]
    v, w = ds.windows(obj)
    chosen = ds.representatives(obj)["chosen"]
    picked = w[np.arange(len(v)), chosen]
    np.testing.assert_allclose(ds.bank(obj, "max-min").profiles, max_min(picked), atol=1e-6)
    np.testing.assert_allclose(ds.bank(obj, "dft321").profiles, dft321(picked), atol=1e-6)
    code, out, err = run(capsys, "bench", "reducers", "--repeats", 2, "--number", 2, "--samples", 5000)
    assert code == 0, err
    assert "helmet-drops" in out.splitlines()[0]


def test_pick_refuses_a_builtin_dataset_which_is_part_of_the_installed_package(dataset, capsys, monkeypatch):
    import hapticfx.data.dataset as dataset_module

    monkeypatch.setattr(dataset_module, "BUILTIN_DIR", dataset.parent)  # the toy dataset as builtin:ds
    before = {p: p.read_bytes() for p in dataset.rglob("*") if p.is_file()}
    for ref in (f"builtin:{dataset.name}", dataset):  # by name or by its path inside the package
        code, _, err = run(capsys, "data", "pick", "wood-beam", 3.13, 1, "--dataset", ref)
        assert code == 2 and err.count("\n") == 1 and "builtin:ds is installed with hapticfx" in err
        assert f"copy it first (cp -r {dataset} my-drops)" in err
    assert {p: p.read_bytes() for p in dataset.rglob("*") if p.is_file()} == before


@pytest.mark.parametrize("velocity", ["nan", "3.5"])
def test_pick_and_plot_refuse_a_velocity_that_is_not_recorded(dataset, tmp_path, capsys, velocity):
    before = (dataset / "dataset.json").read_bytes()
    code, _, err = run(capsys, "data", "pick", "wood-beam", velocity, 1, "--dataset", dataset)
    assert code == 2 and err.count("\n") == 1
    assert f"wood-beam has no drops at {velocity} m/s; recorded: 2.42, 3.13, 3.96" in err
    assert (dataset / "dataset.json").read_bytes() == before
    code, _, err = run(capsys, "data", "plot", "wood-beam", "--dataset", dataset, "--velocity", velocity,
                       "-o", tmp_path / "p.png")
    assert code == 2 and "has no drops at" in err and not (tmp_path / "p.png").exists()


def test_plot_replaces_its_own_png_and_not_a_users_file(dataset, tmp_path, capsys):
    png = tmp_path / "fig.png"
    for _ in range(2):  # the second run replaces the plot the first wrote
        code, _, err = run(capsys, "data", "plot", "wood-beam", "--dataset", dataset, "-o", png)
        assert code == 0, err
    mine = tmp_path / "n.png"
    mine.write_text("precious")
    code, _, err = run(capsys, "data", "plot", "wood-beam", "--dataset", dataset, "-o", mine)
    assert code == 2 and err.count("\n") == 1 and f"{mine}: exists and was not written by hapticfx; use --force" in err
    assert mine.read_text() == "precious"
    code, _, err = run(capsys, "data", "plot", "wood-beam", "--dataset", dataset, "-o", mine, "--force")
    assert code == 0 and mine.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    notes = tmp_path / "notes.txt"  # PNG data under another name, even with --force: refused
    notes.write_text("precious")
    code, _, err = run(capsys, "data", "plot", "wood-beam", "--dataset", dataset, "-o", notes, "--force")
    assert code == 2 and err.count("\n") == 1 and "the plot is a PNG image; give --out a .png file" in err
    assert notes.read_text() == "precious"


def _spoil(dataset, what):
    import json

    meta_file = dataset / "dataset.json"
    meta = json.loads(meta_file.read_text())
    wood = meta["objects"]["wood-beam"]
    if what == "bank representative":
        bank = dataset / "banks" / "max-min" / "wood-beam.npz"
        arrays = dict(np.load(bank))
        np.savez_compressed(bank, **{**arrays, "representative": arrays["representative"] + 100})
        return bank, "representative: 100 at index 0 where dataset.json's objects.wood-beam.representative.chosen has 0"
    if what == "bank profiles cut":  # a 400 ms profile played where the dataset says 500 ms
        bank = dataset / "banks" / "max-min" / "wood-beam.npz"
        arrays = dict(np.load(bank))
        np.savez_compressed(bank, **{**arrays, "profiles_g": arrays["profiles_g"][:, :400]})
        return bank, f"profiles_g: profiles of 400 samples where dataset.json's n_samples is {meta['n_samples']}"
    if what == "NaN velocity":
        wood["velocities_mps"][1] = float("nan")
        key = "velocities_mps"
    elif what == "velocities cut":
        wood["velocities_mps"] = wood["velocities_mps"][:2]
        key = "representative.chosen"
    elif what == "chosen out of range":
        wood["representative"]["chosen"] = [99] * 3
        key = "representative.chosen"
    meta_file.write_text(json.dumps(meta))
    return meta_file, f"objects.wood-beam.{key}: expected"


@pytest.mark.parametrize("what", ["NaN velocity", "velocities cut", "chosen out of range", "bank representative",
                                  "bank profiles cut"])
def test_a_dataset_that_contradicts_itself_is_refused_where_it_is_loaded(dataset, tmp_path, capsys, what):
    file, message = _spoil(dataset, what)
    effect = tmp_path / "e.yaml"
    effect.write_text(f"name: t\nobject: wood-beam\nvelocity_mps: 3.5\nmodel: {{type: data-driven, dataset: '{dataset}', "
                      "reducer: max-min, interpolator: linear}\nactuator: {type: vibro-transducer}\n")
    for argv in (("data", "info", dataset), ("data", "plot", "wood-beam", "--dataset", dataset, "-o", tmp_path / "p.png"),
                 ("render", effect, "-o", tmp_path / "r.csv")):
        code, _, err = run(capsys, *argv)
        assert code == 2 and err.count("\n") == 1 and f"{file}: {message}" in err, (argv, err)
    assert not (tmp_path / "p.png").exists() and not (tmp_path / "r.csv").exists()


def test_tables_reads_every_bank_before_it_rewrites_any_table(dataset, capsys):
    tables = {p: p.read_bytes() for p in (dataset / "tables").iterdir()}
    assert any("dft321" in p.name for p in tables)  # dft321 comes first: it would be rewritten first
    (dataset / "banks" / "max-min" / "steel-plate.npz").write_bytes(b"PK\x03\x04 not a zip")
    code, _, err = run(capsys, "data", "tables", dataset)
    assert code == 2 and err.count("\n") == 1 and "steel-plate.npz: corrupt or unreadable" in err
    assert {p: p.read_bytes() for p in (dataset / "tables").iterdir()} == tables


def test_tables_leaves_a_built_in_dataset_as_it_shipped(capsys):
    from hapticfx.data.dataset import BUILTIN_DIR

    shipped = BUILTIN_DIR / "helmet-drops" / "tables"
    before = {p: p.stat().st_mtime_ns for p in shipped.iterdir()}
    code, _, err = run(capsys, "data", "tables", "builtin:helmet-drops")
    assert code == 2 and err.count("\n") == 1
    assert "builtin:helmet-drops: ships with hapticfx" in err and f"cp -r {shipped.parent} DIR" in err
    assert {p: p.stat().st_mtime_ns for p in shipped.iterdir()} == before


def test_import_names_a_folder_as_a_folder_and_info_says_how_to_make_a_held_out_set(dataset, tmp_path, capsys,
                                                                                     monkeypatch):
    import shutil

    from hapticfx.evaluation import heldout

    (tmp_path / "csv_dir").mkdir()
    code, _, err = run(capsys, "data", "import", tmp_path / "csv_dir", "-o", tmp_path / "x")
    assert code == 2 and err.count("\n") == 1
    assert f"csv_dir: a folder; give the CSV files in it ({tmp_path / 'csv_dir' / '*.csv'})" in err
    code, _, err = run(capsys, "data", "import", tmp_path / "nodir", "-o", tmp_path / "x")
    assert code == 2 and "nodir: file not found" in err and not (tmp_path / "x").exists()

    monkeypatch.setenv("HAPTICFX_CACHE", str(tmp_path / "cache"))
    code, _, err = run(capsys, "data", "info", "heldout:heldout-3drops")
    assert code == 2 and err.count("\n") == 1
    assert ("heldout:heldout-3drops: not simulated on this machine yet; make it with "
            "`hapticfx data synth --heldout heldout-3drops`") in err
    code, _, err = run(capsys, "data", "info", "heldout:nope")
    assert code == 2 and "no held-out set 'nope'; known: heldout-irregular" in err
    shutil.copytree(dataset, heldout.dataset_path("heldout-3drops"))  # as if simulated: info reads it
    code, out, err = run(capsys, "data", "info", "heldout:heldout-3drops")
    assert code == 0 and f"path: {heldout.dataset_path('heldout-3drops')}" in out, err
