"""Sweeps from Python: the sweep's table, its points the module's runs."""

import sys

import numpy as np
import pytest

import stickslip
from stickslip import _sweep
from conftest import PAIR_TOML

SWEEP = """\
[sweep]
case = "base.toml"
[vary]
drive.velocity = [1e-3, 5e-4]
"""


@pytest.fixture
def sweep_file(tmp_path):
    (tmp_path / "base.toml").write_text(
        PAIR_TOML.replace("t_end = 1e-3", "t_end = 6e-4").replace("average_from = 3e-4", "average_from = 2e-4"))
    (tmp_path / "velocity.toml").write_text(SWEEP)
    return tmp_path / "velocity.toml"


def test_a_sweep_returns_its_table_and_its_points_are_the_modules_runs(sweep_file, tmp_path):
    table = stickslip.sweep(sweep_file, jobs=2, out=tmp_path / "out", progress=False)
    assert table["point"].tolist() == ["velocity=0.001", "velocity=0.0005"]
    assert table["status"].tolist() == ["finished", "finished"]
    base = stickslip.Case.from_toml(sweep_file.parent / "base.toml")
    for point, velocity, mu in zip(table["point"], table["drive.velocity"], table["mu"]):
        direct = stickslip.run(base.replace({"drive.velocity": velocity}))
        assert stickslip.load(tmp_path / "out" / point).mu == direct.mu  # bit for bit
        assert mu == pytest.approx(direct.mu, rel=1e-6)  # sweep.csv prints 7 digits
    # `set` applies to every point, as --set does; finished points are kept.
    again = stickslip.sweep(sweep_file, jobs=1, out=tmp_path / "out", progress=False)
    assert again["mu"].tolist() == table["mu"].tolist()
    with pytest.raises(stickslip.CaseError, match="lattice.nz: must be >= 2"):
        stickslip.sweep(sweep_file, out=tmp_path / "other", set={"lattice.nz": 1})
    with pytest.raises(stickslip.CaseError, match="drive.velocity: .* varies it"):
        stickslip.sweep(sweep_file, out=tmp_path / "other", set={"drive.velocity": 5e-4})


def test_without_pandas_the_table_is_a_dict_of_arrays(sweep_file, tmp_path, monkeypatch):
    stickslip.sweep(sweep_file, jobs=2, out=tmp_path / "out", progress=False)
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas now fails
    table = _sweep._read_csv(tmp_path / "out" / "sweep.csv")
    assert isinstance(table, dict)
    assert table["point"].tolist() == ["velocity=0.001", "velocity=0.0005"]
    assert table["mu"].dtype == np.float64 and table["mu"].shape == (2,)
