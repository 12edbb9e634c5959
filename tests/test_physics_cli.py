"""`hapticfx data synth` and `hapticfx bench contact` through the real CLI entry point."""

from __future__ import annotations

import numpy as np
import pytest

from hapticfx.cli import main
from hapticfx.bench import contact as contact_bench
from hapticfx.data.dataset import open_dataset


def run(capsys, *argv):
    with pytest.raises(SystemExit) as exit_:
        main(list(map(str, argv)))
    out = capsys.readouterr()
    return exit_.value.code, out.out, out.err


def test_data_synth_writes_a_readable_dataset_and_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "sim"
    args = ("data", "synth", out, "--objects", "plastic-frame,steel-plate", "--velocities", "2.42,3.96",
            "--drops", 2, "--jobs", 1, "--seed", 3)
    code, stdout, err = run(capsys, *args)
    assert code == 0, err
    assert "steel-plate: 3.96 m/s done" in err  # progress on stderr
    ds = open_dataset(out)
    assert sorted(ds.objects) == ["plastic-frame", "steel-plate"]
    v, acc = ds.raw("steel-plate")
    assert np.allclose(v, [2.42, 3.96]) and acc.shape == (2, 2, 700, 3)
    assert ds.bank("plastic-frame", "dft321").profiles.shape == (2, 500)
    prov = ds.meta["provenance"]
    assert prov["seed"] == 3 and prov["command"].startswith(f"hapticfx data synth {out}")
    code, _, err = run(capsys, *args)
    assert code == 2 and "already exists" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("argv,message", [
    (("--objects", "anvil"), "unknown object 'anvil'"),
    (("--velocities", "2,fast"), "--velocities must be comma-separated numbers"),
    (("--velocities", "0,2"), "--velocities: 0 m/s is outside 0.05-50 m/s"),
    # said once the simulation had started, and of a drop's varied velocity, not the one typed
    (("--velocities", "1e9,1e10"), "--velocities: 1e+09 m/s is outside 0.05-50 m/s, the drop rig's range"),
])
def test_data_synth_bad_input_is_one_line(tmp_path, capsys, argv, message):
    code, _, err = run(capsys, "data", "synth", tmp_path / "x", "--drops", 1, *argv)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()


def test_data_synth_checks_its_input_and_output_before_simulating(tmp_path, capsys, monkeypatch):
    one = ("--objects", "concrete-brick", "--drops", 1, "--jobs", 1)
    (tmp_path / "afile").write_text("x")
    for out, argv, message in (
        ("x", ("--seed", -1), "Invalid value for '--seed': -1 is not in the range 0<=x<=4294967295"),
        ("x", ("--velocities", ""), "--velocities is empty"),  # not the default 12
        ("nodir/x/s", ("--velocities", 3), "object 'concrete-brick': needs drops at 2 or more velocities"),
        ("afile/s", ("--velocities", "3,4"), "afile: not a folder"),
    ):
        code, _, err = run(capsys, "data", "synth", tmp_path / out, *one, *argv)
        assert code == 2 and message in err and "done" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]

    import tempfile

    def refused(*args, dir, **kw):
        raise PermissionError(13, "Permission denied", f"{dir}/.s.hidden")

    monkeypatch.setattr(tempfile, "mkdtemp", refused)  # a folder it may not write in, even as root
    code, _, err = run(capsys, "data", "synth", tmp_path / "s", *one, "--velocities", "3,4")
    assert code == 2 and err == f"hapticfx: error: {tmp_path / 's'}: cannot be written (Permission denied)\n"


def test_data_synth_builtin_takes_no_other_choices(capsys):
    code, _, err = run(capsys, "data", "synth", "--builtin", "--drops", 3)
    assert code == 2 and "--builtin regenerates the packaged dataset exactly" in err


def test_bench_contact_rejects_unknown_solver(capsys):
    code, _, err = run(capsys, "bench", "contact", "--solvers", "Euler")
    assert code == 2 and "unknown solver 'Euler'" in err


def test_bench_contact_times_renders_that_integrate_up_to_its_fastest_velocity():
    """The render rows time direct integration (the model's default serves a table up to 10 m/s: the grid's
    50 m/s was refused, and every other render would have built a table first)."""
    rows = contact_bench.renders(stiffness=(1e6,), masses=(0.1,), velocities=(0.5, 50.0), repeats=1)
    assert rows[0]["renders"] == 2 and rows[0]["peak_g"][1] > rows[0]["peak_g"][0] > 0


def test_bench_rows_measure_error_against_the_reference():
    case = contact_bench.Case("short", 1e7, 3.96, duration_s=0.02)
    rows = contact_bench.run(cases=[case], solvers=["RK45", "LSODA"], rtols=[1e-3, 1e-8], repeats=1)
    assert [(r["solver"], r["rtol"]) for r in rows] == [("RK45", 1e-3), ("LSODA", 1e-3), ("RK45", 1e-8), ("LSODA", 1e-8)]
    by = {(r["solver"], r["rtol"]): r for r in rows}
    for solver in ("RK45", "LSODA"):
        assert by[(solver, 1e-8)]["pos_err_um"] < by[(solver, 1e-3)]["pos_err_um"]
        assert by[(solver, 1e-8)]["evaluations"] > by[(solver, 1e-3)]["evaluations"]
    assert by[("RK45", 1e-3)]["ratio"] == 1.0
    assert rows[0]["ref_pos_err_um"] < 1e-2  # the reference agrees with an independent tight solution
    table = contact_bench.table(rows)
    assert "| short | LSODA | 1e-08 |" in table
