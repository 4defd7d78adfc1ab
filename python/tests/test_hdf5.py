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
