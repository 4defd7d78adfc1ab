"""run.h5 read without this package: plain h5py sees dimension scales (time,
contact ids) and units; xarray opens a table as a Dataset (h5netcdf)."""

import h5py
import numpy as np
import pytest

import stickslip


@pytest.fixture(scope="module")
def h5_run(tmp_path_factory):
    from conftest import PAIR_TOML

    dir = tmp_path_factory.mktemp("h5")
    (dir / "pair.toml").write_text(PAIR_TOML)
    case = stickslip.Case.from_toml(dir / "pair.toml").replace(
        {"output.format": "hdf5", "output.steps": True})
    return stickslip.run(case, out=dir / "out")


def test_datasets_have_dimension_scales_and_units(h5_run):
    with h5py.File(h5_run.dir / "run.h5", "r", locking=False) as f:
        friction = f["friction"]
        assert h5py.h5ds.is_scale(friction["t"].id)
        for name in ("F_f", "mu_inst"):
            ds = friction[name]
            assert ds.dims[0].label == "" and ds.dims[0].keys() == ["t"]
            assert ds.dims[0]["t"] == friction["t"]
        assert friction["t"].attrs["units"] == "s"
        assert friction["F_f"].attrs["units"] == "N" and friction["mu_inst"].attrs["units"] == "1"
        traces = f["traces"]
        vx = traces["vx"]
        assert vx.dims[0].keys() == ["t"] and vx.dims[1].keys() == ["contact"]
        assert vx.dims[1]["contact"][()].tolist() == [0, 1]
        assert vx.attrs["units"] == "m/s"
        for group in ("events", "slips", "steps", "contacts"):
            g = f[group]
            first = next(iter(g))  # time (slips: t_end; contacts: id)
            assert h5py.h5ds.is_scale(g[first].id), group
            for name in g:
                if name != first:
                    assert g[name].dims[0].keys() == [first], (group, name)
                    if np.issubdtype(g[name].dtype, np.floating):
                        assert "units" in g[name].attrs, (group, name)
        assert f["slips/peak_speed"].attrs["units"] == "m/s"


def test_the_package_still_reads_it(h5_run):
    again = stickslip.load(h5_run.dir)
    np.testing.assert_array_equal(again.traces.contact, [0, 1])
    np.testing.assert_array_equal(again.traces.vx, h5_run.traces.vx)
    assert set(again.tables) == {"steps"}


def test_xarray_opens_a_table_as_a_labelled_dataset(h5_run):
    xarray = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    path = h5_run.dir / "run.h5"
    with xarray.open_dataset(path, group="friction", engine="h5netcdf") as ds:
        assert ds["F_f"].dims == ("t",) and ds["F_f"].attrs["units"] == "N"
        np.testing.assert_array_equal(ds["t"].values, h5_run.friction.t)
    with xarray.open_dataset(path, group="traces", engine="h5netcdf") as ds:
        assert ds["vx"].dims == ("t", "contact")
        assert ds["contact"].values.tolist() == [0, 1]
        np.testing.assert_array_equal(ds["vx"].sel(contact=1).values, h5_run.traces.vx[:, 1])


@pytest.mark.filterwarnings("ignore::stickslip.MuWarning")  # 0.5 ms: still loading
def test_a_restart_keeps_the_scales_and_gives_an_older_file_them(tmp_path):
    from conftest import PAIR_TOML

    (tmp_path / "pair.toml").write_text(PAIR_TOML)
    case = stickslip.Case.from_toml(tmp_path / "pair.toml").replace(
        {"output.format": "hdf5", "output.final_state": True, "run.t_end": 5e-4})
    for older in (False, True):
        out = tmp_path / f"older={older}"
        stickslip.run(case, out=out)
        if older:  # as written before tables had dimension scales: no scale attributes
            with h5py.File(out / "run.h5", "r+") as f:
                for group in f.values():
                    for ds in group.values():
                        for name in ("DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME"):
                            if name in ds.attrs:
                                del ds.attrs[name]
                assert not h5py.h5ds.is_scale(f["friction/t"].id)
        longer = stickslip.run(case.replace({"run.t_end": 1e-3}), out=out, restart=True)
        assert longer.friction.t.size == 1001
        with h5py.File(out / "run.h5", "r") as f:
            assert h5py.h5ds.is_scale(f["friction/t"].id), older
            assert f["friction/F_f"].dims[0].keys() == ["t"], older
            assert f["traces/vy"].dims[1].keys() == ["contact"], older
            assert f["traces/vy"].shape == (1001, 2)
