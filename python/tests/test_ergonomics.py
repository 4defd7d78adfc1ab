"""A run's tables as pandas DataFrames and an xarray Dataset, short reprs,
threads= and a progress bar where stderr is no terminal (a notebook)."""

import pickle

import numpy as np
import pandas as pd
import pytest

import stickslip


@pytest.fixture(scope="module")
def pair_run(tmp_path_factory):
    from conftest import PAIR_TOML

    out = tmp_path_factory.mktemp("pair") / "out"
    path = out.parent / "pair.toml"
    path.write_text(PAIR_TOML)
    return stickslip.run(stickslip.Case.from_toml(path), out=out)


def test_tables_are_dataframes_with_the_csvs_columns(pair_run):
    run = pair_run
    for name in ("friction", "traces", "events", "slips", "contacts"):
        table = getattr(run, name)
        from_csv = pd.read_csv(run.dir / f"{name}.csv")
        frame = table.to_pandas()
        assert sorted(frame.columns) == sorted(from_csv.columns), name
        assert len(frame) == len(from_csv), name
        pd.testing.assert_frame_equal(pd.DataFrame(table), frame)  # a mapping of its columns
    f = pd.DataFrame(run.friction)
    assert list(f.columns) == ["t", "F_f", "mu_inst"]
    np.testing.assert_array_equal(f["F_f"], run.friction.F_f)
    traces = run.traces.to_pandas()
    assert list(traces.columns) == ["t", "vx_0", "vy_0", "vx_1", "vy_1"]
    np.testing.assert_array_equal(traces["vy_1"], run.traces.vy[:, 1])
    assert run.events.to_pandas()["kind"].iloc[0] == "slip"
    with pytest.raises(TypeError, match="read-only"):
        run.friction["F_f"] = None
    again = pickle.loads(pickle.dumps(run.traces))
    assert list(again) == list(run.traces) and np.array_equal(again.vx, run.traces.vx)


def test_reprs_are_short(pair_run):
    run = pair_run
    text = repr(run)
    assert len(text) < 400 and len(text.splitlines()) == 3, text
    assert f"μ = {run.mu:.6g}" in text and "method dirk" in text and "t_end 0.001 s" in text
    assert "traces (1001 × 2 contacts)" in text and "slips (" in text
    assert repr(run.friction) == "Friction(1001 rows: t, F_f, mu_inst)"
    assert repr(run.traces) == "Traces(1001 times × 2 contacts [0, 1]: vx, vy)"
    assert repr(run.contacts) == "Contacts(2 rows: id, ix, iy, v_star)"


def test_to_xarray_labels_time_contact_and_units(pair_run):
    xarray = pytest.importorskip("xarray")
    run = pair_run
    ds = run.to_xarray()
    assert isinstance(ds, xarray.Dataset)
    assert ds["F_f"].dims == ("t",) and ds["vx"].dims == ("t", "contact")
    assert ds["t"].attrs["units"] == "s" and ds["F_f"].attrs["units"] == "N"
    assert ds["vx"].attrs["units"] == "m/s" and ds["mu_inst"].attrs["units"] == "1"
    assert ds["contact"].values.tolist() == [0, 1]
    assert ds["v_star"].values.tolist() == [4.75e-4, 2.09e-3]
    np.testing.assert_array_equal(ds["vx"].sel(contact=1).values, run.traces.vx[:, 1])
    np.testing.assert_array_equal(ds["t"].values, run.friction.t)
    assert ds.attrs["mu"] == run.mu
    # How far to trust it travels with it: the verdict, its error bar, θ.
    assert ds.attrs["theta"] == run.summary["theta"]
    assert ds.attrs["regime"] == run.summary["regime"]["kind"]
    assert ds.attrs["mu_trusted"] == int(run.mu_trusted)
    assert ds.attrs["mu_error"] == run.mu_error == run.summary["mu_error"]


def test_load_of_a_missing_directory_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such run directory"):
        stickslip.load(tmp_path / "nonexistent")
    with pytest.raises(stickslip.OutputError, match="holds no run"):
        stickslip.load(tmp_path)  # there, but no run in it


def test_threads_sets_the_solvers_threads_and_leaves_the_numbers(pair_file):
    one = stickslip.run(pair_file, threads=1)
    two = stickslip.run(pair_file, threads=2)
    assert one.summary["solver"]["threads"] == 1 and two.summary["solver"]["threads"] == 2
    assert one.mu == two.mu
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match="threads"):
            stickslip.run(pair_file, threads=bad)


def test_progress_without_a_terminal_is_a_tqdm_bar(pair_file, capsys):
    pytest.importorskip("tqdm")
    case = stickslip.Case.from_toml(pair_file)  # reported at the first output time, however short
    stickslip.run(case, progress=True)
    err = capsys.readouterr().err
    assert "steps" in err and "/0.001 s" in err, err
    assert "100%" in err and "0.001/0.001 s" in err, err  # closed at t_end
    quiet = stickslip.run(case)
    assert capsys.readouterr().err == ""
    assert quiet.mu is not None
