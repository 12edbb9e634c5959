"""Registration stays cheap; the commands answer; the benchmark runs end to end on a tiny dataset."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import yaml
from neural_testkit import TINY_BY_ARCH, tiny_config

from hapticfx_neural.plugin import INTERPOLATORS


def _run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True)


def test_registration_and_linear_playback_never_import_torch(tmp_path, syn_dataset):
    effect = tmp_path / "dd.yaml"
    effect.write_text(f"name: dd\nobject: plastic-frame\nmodel: {{type: data-driven, dataset: {syn_dataset}, "
                      "interpolator: linear}\nactuator: {type: memory}\n")
    r = _run(f"""
        import json, sys
        import hapticfx
        from hapticfx.registry import get_registry
        from hapticfx.cli import build_app
        names = get_registry().names("interpolator"); build_app()
        from hapticfx.pipeline import Pipeline
        with Pipeline.from_effect({str(effect)!r}) as p:
            p.impact(velocity=3.3)
        print(json.dumps([names, "torch" in sys.modules]))
    """)
    assert r.returncode == 0, r.stderr
    names, torch_loaded = json.loads(r.stdout.strip().splitlines()[-1])
    assert set(INTERPOLATORS) <= set(names)
    assert torch_loaded is False


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "hapticfx", *args], capture_output=True, text=True)


def test_train_command_and_clear_errors(tmp_path, syn_dataset):
    cfg = tiny_config(tmp_path, syn_dataset, epochs=2)
    r = _cli("train", str(cfg), "--quiet")
    assert r.returncode == 0, r.stderr
    assert "wrote" in r.stdout and (tmp_path / "ck-convbilstm" / "model.json").is_file()
    bad = tmp_path / "bad.yaml"
    bad.write_text("interpolator: convbilstm\ndataset: x\ntraining: {epoch: 3}\n")
    r = _cli("train", str(bad))
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert f"{bad}: training: unknown key(s) epoch" in r.stderr


def test_learning_curves_say_where_training_started(tmp_path, syn_dataset):
    from PIL import Image

    cfg = tiny_config(tmp_path, syn_dataset, epochs=2)
    r = _cli("train", str(cfg), "--quiet", "--curves", str(tmp_path / "scratch.png"))
    assert r.returncode == 0, r.stderr
    tuned = tmp_path / "tune.yaml"
    tuned.write_text(yaml.safe_dump({**yaml.safe_load(cfg.read_text()), "out": str(tmp_path / "tuned"),
                                     "init": str(tmp_path / "ck-convbilstm" / "model.safetensors")}))
    r = _cli("train", str(tuned), "--quiet", "--curves", str(tmp_path / "tuned.png"))
    assert r.returncode == 0, r.stderr
    titles = [Image.open(tmp_path / f"{n}.png").text["Title"] for n in ("scratch", "tuned")]
    assert titles[0] == "convbilstm on synthetic"
    assert titles[1] == "convbilstm on synthetic, fine-tuned from weights pre-trained on synthetic"


def test_a_curves_path_the_png_cannot_go_to_is_refused_before_training(tmp_path, syn_dataset):
    cfg = tiny_config(tmp_path, syn_dataset, epochs=1)
    (tmp_path / "mine.png").write_text("my picture")
    (tmp_path / "cdir.png").mkdir()
    (tmp_path / "a-file").write_text("x")
    for curves, said in (("c.txt", "expected a .png file name, got '.txt'"),
                         ("mine.png", "exists and was not written by hapticfx; use --force"),
                         ("cdir.png", "is a directory, expected a file name"), ("a-file/c.png", "not a folder")):
        r = _cli("train", str(cfg), "--quiet", "--curves", str(tmp_path / curves))
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and said in r.stderr, (curves, r.stderr)
        assert not (tmp_path / "ck-convbilstm").exists(), curves  # refused before training
    assert (tmp_path / "mine.png").read_text() == "my picture"
    r = _cli("train", str(cfg), "--quiet", "--curves", str(tmp_path / "mine.png"), "--force")
    assert r.returncode == 0 and (tmp_path / "mine.png").read_bytes()[:4] == b"\x89PNG", r.stderr


def test_bench_interpolators_trains_networks_per_round_and_serves_them_from_tables(tmp_path, syn_dataset):
    rows = tmp_path / "rows.yaml"
    rows.write_text(yaml.safe_dump({
        "convbilstm-tiny": {"interpolator": "convbilstm", "model": TINY_BY_ARCH["convbilstm"]},
        "lstm": {"model": TINY_BY_ARCH["lstm"]},
    }))
    out = tmp_path / "bench"
    r = _cli("bench", "interpolators", "--dataset", str(syn_dataset), "--methods", "convbilstm-tiny,lstm",
             "--protocol", "paper", "--epochs", "2", "--repeats", "5", "--config", str(rows), "--out", str(out))
    assert r.returncode == 0, r.stderr[-2000:]
    res = json.loads((out / "results.json").read_text())
    summary = res["summary"]["methods"]
    assert set(summary) == {"linear", "convbilstm-tiny", "lstm"}
    assert sorted({f["velocity"] for f in res["results"]["folds"]}) == [3.96, 4.43]
    for row in ("convbilstm-tiny", "lstm"):
        assert summary[row]["table_vs_direct_max"] <= 1e-6
        assert summary[row]["table_latency_ms"]["median"] < summary[row]["latency_ms"]["median"]
        assert summary[row]["extra"]["epochs_run"] == 2
        epochs = summary[row]["best_epochs"]
        assert len(epochs) == 1 and 0 <= epochs[0] <= 2
        assert f"| {row} | {summary[row]['fit_s']:.2f} | {epochs[0]} | " in r.stdout  # the run-time table says it
    assert "best_epochs" not in summary["linear"]
    assert "### RMSE vs representative (g)" in r.stdout
    assert "convbilstm-tiny, round 1" in r.stderr and "best epoch" in r.stderr  # each network's epochs, as it trains


def test_bench_rounds_of_networks_trained_side_by_side_score_as_serial_rounds(tmp_path, syn_dataset):
    rows = tmp_path / "rows.yaml"
    rows.write_text(yaml.safe_dump({"lstm": {"model": TINY_BY_ARCH["lstm"]}}))
    scores = {}
    for jobs in ("1", "2"):
        out = tmp_path / f"bench-{jobs}"
        r = _cli("bench", "interpolators", "--dataset", str(syn_dataset), "--methods", "lstm", "--max-rounds", "2",
                 "--epochs", "2", "--repeats", "5", "--config", str(rows), "--out", str(out), "--jobs", jobs)
        assert r.returncode == 0, r.stderr[-2000:]
        folds = json.loads((out / "results.json").read_text())["results"]["methods"]["lstm"]["folds"]
        scores[jobs] = [(f["round"], f["object"], f["velocity"], f["rmse"], f["lsd_db"]) for f in folds]
    assert scores["2"] == scores["1"] and len({s[0] for s in scores["1"]}) == 2
    # each process's lines name its round; the networks' epochs come as lines
    assert "2 rounds in 2 processes" in r.stderr
    assert "[1/2]   lstm: fitting" not in r.stderr and "[1/2] lstm: fitting" in r.stderr
    assert "[2/2] lstm: fitted in" in r.stderr and "lstm, round 2: 2/2 epochs" in r.stderr


def test_shipped_weights_play_the_brick_with_convbilstm(tmp_path):
    import numpy as np
    import pytest

    from hapticfx.data.dataset import BUILTIN_DIR
    from hapticfx_neural.checkpoint import default_weights

    if not (BUILTIN_DIR / "helmet-drops" / "dataset.json").is_file():
        pytest.skip("the built-in helmet-drops dataset is not generated in this tree")
    assert default_weights("helmet-drops", "max-min", "convbilstm") is not None
    effect = tmp_path / "brick.yaml"
    effect.write_text("name: brick\nobject: concrete-brick\nmodel: {type: data-driven, dataset: builtin:helmet-drops, "
                      "reducer: max-min, interpolator: convbilstm}\nactuator: {type: memory}\n")
    from hapticfx.pipeline import Pipeline

    with Pipeline.from_effect(effect) as p:
        d = p.impact(velocity=3.8)
    assert d.profile.n_samples == 500 and np.all(np.isfinite(d.profile.samples)) and d.profile.peak > 0


def test_bench_learnable_takes_gaps_and_trims_says_when_it_cannot_validate_refuses_bad_ones(tmp_path, drop_dataset):
    cfg = tiny_config(tmp_path, drop_dataset)
    r = _cli("bench", "learnable", str(cfg), "--gaps", "1,2")
    assert r.returncode == 0, r.stderr
    assert "gaps [1, 2]" in r.stdout and "share of the mean square that is sampling noise" in r.stdout
    bad = _cli("bench", "learnable", str(cfg), "--gaps", "0")
    assert bad.returncode == 2 and "--gaps" in bad.stderr and "Traceback" not in bad.stderr
    few = _cli("bench", "learnable", str(cfg))  # 4 targets: too few for a validation split, said, not NaN
    assert few.returncode == 0 and "none: the split needs 5 target velocities" in few.stdout
    assert "nan" not in few.stdout and "Warning" not in few.stderr
    bad = _cli("bench", "learnable", str(cfg), "--trim", "0.5")
    assert bad.returncode == 2 and "trim" in bad.stderr and "with --trim" in bad.stderr
    assert "Traceback" not in bad.stderr
    cfg.write_text(cfg.read_text() + "inputs: pooled\n")  # its noise budget is that of the raw centres
    bad = _cli("bench", "learnable", str(cfg))
    assert bad.returncode == 2 and "inputs: pooled" in bad.stderr and str(cfg) in bad.stderr
    assert "Traceback" not in bad.stderr


def test_bench_learnable_trim_moves_where_the_blend_starts_not_the_noise_budget(tmp_path):
    from hapticfx.data.build import build_dataset
    from hapticfx.data.toy import toy_recordings
    from hapticfx.objects import PAPER_OBJECTS

    rec = toy_recordings(PAPER_OBJECTS["wood-beam"], [2.2, 2.5, 2.8, 3.1, 3.4, 3.7, 4.0, 4.3], drops=5, seed=4)
    ds = build_dataset(tmp_path / "eight", [rec], name="eight", rate_hz=1000.0, sensor={},
                       provenance={"generator": "hapticfx.data.toy (tests)"})
    cfg = tiny_config(tmp_path, ds)
    plain, median = (_cli("bench", "learnable", str(cfg), "--trim", t) for t in ("0", "0.4"))
    assert plain.returncode == 0 and median.returncode == 0, plain.stderr + median.stderr
    assert "trim 0\n" in plain.stdout and "trim 0.4\n" in median.stdout and "nan" not in plain.stdout + median.stdout
    row = lambda out, what: next(line for line in out.splitlines() if line.startswith(f"| {what}"))  # noqa: E731
    # the noise budget is of plain drop means whatever the trim; the blend the learner starts from is not
    assert row(plain.stdout, "blend of drop means") == row(median.stdout, "blend of drop means")
    assert row(plain.stdout, "validation RMSE (normalised)") != row(median.stdout, "validation RMSE (normalised)")


def test_bench_threads_compares_thread_counts_under_load(tmp_path, syn_dataset):
    cfg = tiny_config(tmp_path, syn_dataset, epochs=1)
    r = _cli("bench", "threads", "--config", str(cfg), "--epochs", "1", "--busy", "1")
    assert r.returncode == 0, r.stderr
    rows = [line for line in r.stdout.splitlines() if line.startswith("| convbilstm training epoch")]
    assert [row.split("|")[2].strip() for row in rows] == ["1", "2"]
    assert "with 1 other busy process(es)" in r.stdout and "fastest here:" in r.stdout
    r = _cli("bench", "threads", "--config", str(cfg), "--counts", "0")
    assert r.returncode == 2 and "thread counts must be >= 1" in r.stderr


def test_the_shipped_convbilstm_plays_from_its_table_without_torch(tmp_path):
    effect = tmp_path / "brick.yaml"
    effect.write_text("name: brick\nobject: concrete-brick\nmodel: {type: data-driven, dataset: builtin:helmet-drops, "
                      "interpolator: convbilstm}\nactuator: {type: memory}\n")
    r = _run(f"""
        import json, sys
        from hapticfx.pipeline import Pipeline
        with Pipeline.from_effect({str(effect)!r}) as p:
            peaks = [p.impact(velocity=v).profile.peak for v in (2.5, 3.8, 5.1)]
            served = p.model.describe()["served_from"]["table"]
        print(json.dumps([peaks, served, "torch" in sys.modules]))
    """)
    assert r.returncode == 0, r.stderr
    peaks, served, torch_loaded = json.loads(r.stdout.strip().splitlines()[-1])
    assert served.endswith("convbilstm/model.table.npz") and all(p > 0 for p in peaks)
    assert torch_loaded is False


def test_the_shipped_table_equals_direct_inference():
    import numpy as np

    from hapticfx.data.dataset import open_dataset
    from hapticfx.registry import get_registry

    ds = open_dataset("builtin:helmet-drops")
    tabled = get_registry().create("interpolator", "convbilstm")
    direct = get_registry().create("interpolator", "convbilstm", cache=False)
    rng = np.random.default_rng(5)
    for obj in ds.objects:
        bank = ds.bank(obj, "max-min")
        tabled.prepare(bank, dataset=ds)
        direct.prepare(bank, dataset=ds)
        for v in rng.uniform(bank.velocities[0], bank.velocities[-1], 25):
            lo, hi = bank.neighbours(float(v))
            a, b = tabled.interpolate(lo, hi, float(v)), direct.interpolate(lo, hi, float(v))
            assert np.max(np.abs(a - b)) <= 1e-6 * np.max(np.abs(b))


def test_bench_table_compares_a_trained_table_with_its_network(trained, syn_dataset):
    r = _cli("bench", "table", "--weights", str(trained.parent), "--dataset", str(syn_dataset), "--velocities", "40",
             "--repeats", "5")
    assert r.returncode == 0, r.stderr
    rows = {line.split("|")[1].strip(): line.split("|")[2].strip() for line in r.stdout.splitlines()
            if line.startswith("| ") and "value" not in line}
    assert float(rows["largest abs(table - direct) / peak, random velocities"]) <= 1e-6
    assert float(rows["largest jump / peak at r +- 1e-9 m/s, table"]) <= 1e-6
    assert float(rows["largest jump / peak at r +- 1e-9 m/s, direct"]) <= 1e-6


def test_weights_without_safetensors_are_one_line_naming_the_install_command(tmp_path):
    """torch installed but not safetensors: direct inference (`bench render`'s cache: false) says what to install,
    in one line with exit 2, instead of a ModuleNotFoundError traceback."""
    import subprocess
    import sys
    from pathlib import Path

    import yaml

    repo = Path(__file__).resolve().parents[3]
    effect = yaml.safe_load((repo / "effects" / "falling_brick_convbilstm.yaml").read_text())
    effect["model"]["interpolator_options"] = {**effect["model"].get("interpolator_options", {}), "cache": False}
    path = tmp_path / "direct.yaml"
    path.write_text(yaml.safe_dump(effect))
    code = ("import sys\nsys.modules['safetensors'] = None\nfrom hapticfx.cli import main\n"
            f"sys.argv = ['hapticfx', 'render', {str(path)!r}, '--out', {str(tmp_path / 'x.wav')!r}]\nmain()\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().splitlines() == [
        f"hapticfx: error: {path}: model: reading or writing network weights needs safetensors, which is not "
        "installed: pip install 'hapticfx-neural[train]'"]
