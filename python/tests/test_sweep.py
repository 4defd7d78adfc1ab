"""Sweeps from Python: the sweep's table, its points the module's runs."""

import signal
import subprocess
import sys
import time

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
    # The directory is a sweep's: load says how to read it, load_sweep reads it.
    with pytest.raises(stickslip.OutputError, match=r"a sweep directory: read its sweep.csv with "
                       r"stickslip.load_sweep\("):
        stickslip.load(tmp_path / "out")
    assert stickslip.load_sweep(tmp_path / "out")["mu"].tolist() == table["mu"].tolist()
    with pytest.raises(stickslip.OutputError, match="no sweep.csv"):
        stickslip.load_sweep(tmp_path / "out" / "velocity=0.001")
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


INTERRUPTED_SWEEP = """
import sys, stickslip
try:
    stickslip.sweep(sys.argv[1], jobs=2, out=sys.argv[2])
except stickslip.Interrupted as stop:
    print(stop.signal)
    sys.exit(3)
"""


def test_interrupting_the_kernel_stops_a_sweeps_points_with_a_checkpoint(tmp_path):
    # A notebook's "interrupt kernel" is SIGINT to the Python process alone,
    # not to the points the sweep runs. Each point is 0.1 s of the pair under
    # imex at rtol 1e-7, minutes of computing: one that is not stopped is
    # still running when the test gives up, 20 s after the signal.
    (tmp_path / "base.toml").write_text(PAIR_TOML.replace("t_end = 1e-3", "t_end = 0.1") + """
[solver]
method = "imex"
rtol = 1e-7
atol_displacement = 1e-13
atol_velocity = 1e-8
""")
    (tmp_path / "velocity.toml").write_text(SWEEP)
    out = tmp_path / "out"
    child = subprocess.Popen([sys.executable, "-c", INTERRUPTED_SWEEP, str(tmp_path / "velocity.toml"),
                              str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while len(list(out.glob("*/friction.csv"))) < 2 and child.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    child.send_signal(signal.SIGINT)
    try:
        stdout, stderr = child.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        child.send_signal(signal.SIGTERM)  # which the sweep passes on: its points stop
        child.communicate(timeout=60)
        pytest.fail("the sweep's points ran on after SIGINT")
    assert child.returncode == 3, stderr
    assert stdout.strip() == str(int(signal.SIGINT))
    for point in ("velocity=0.001", "velocity=0.0005"):
        assert (out / point / "checkpoint.bin").exists()
        assert not (out / point / "summary.json").exists()
        assert "interrupted at t = " in (out / point / "run.log").read_text()
