"""Runs from Python: the command line's numbers, as numpy arrays."""

import json
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import stickslip
from conftest import EXECUTABLE, PAIR_TOML, cli


def test_the_module_and_the_command_line_give_the_same_run_bit_for_bit(pair_file, tmp_path):
    cli("run", pair_file, "--out", tmp_path / "cli", "--quiet")
    case = stickslip.Case.from_toml(pair_file)
    run = stickslip.run(case, out=tmp_path / "py")
    from_cli = stickslip.load(tmp_path / "cli")
    assert run.summary["mu"] == from_cli.summary["mu"]
    assert run.summary["solver_stats"] == from_cli.summary["solver_stats"]
    assert run.summary["energy_residual"] == from_cli.summary["energy_residual"]
    for table in ("events.csv", "slips.csv", "friction.csv", "traces.csv"):
        assert (tmp_path / "py" / table).read_bytes() == (tmp_path / "cli" / table).read_bytes()
    # Without `out` nothing is kept, and the numbers are the same.
    in_memory = stickslip.run(case)
    assert in_memory.dir is None
    assert in_memory.summary["mu"] == from_cli.summary["mu"]
    assert in_memory.summary["solver_stats"]["steps"] == from_cli.summary["solver_stats"]["steps"]
    np.testing.assert_array_equal(in_memory.events.t, from_cli.events.t)
    np.testing.assert_array_equal(in_memory.traces.vx, from_cli.traces.vx)


def test_arrays_have_the_documented_shapes_and_units(pair_file):
    case = stickslip.Case.from_toml(pair_file)
    run = stickslip.run(case)
    n = 1001  # t = 0, 1 µs, ..., 1 ms
    f = run.friction
    assert f.t.shape == f.F_f.shape == f.mu_inst.shape == (n,)
    np.testing.assert_allclose(f.t, np.arange(n) * 1e-6, rtol=0, atol=1e-18)  # seconds
    np.testing.assert_allclose(f.mu_inst, f.F_f / run.summary["F_N"], rtol=1e-9)  # N / N
    tr = run.traces
    assert tr.contact.tolist() == run.contacts.id.tolist() == [0, 1]
    assert tr.vx.shape == tr.vy.shape == (n, 2)
    np.testing.assert_array_equal(tr.t, f.t)
    # m/s: contact 0 sticks (|v| far below v* = 4.75e-4 m/s) and slips (far above) in turn.
    assert np.min(np.abs(tr.vx[:, 0])) < 1e-5 and np.max(tr.vx[:, 0]) > 4.75e-3
    c = run.contacts
    assert c.ix.tolist() == [1, 4] and c.iy.tolist() == [2, 2]
    assert c.v_star.tolist() == [4.75e-4, 2.09e-3]
    e = run.events
    assert len(e.t) == len(e.contact) == len(e.kind) == len(e.speed) == len(e.force) >= 4  # both contacts slip and stick once
    assert np.all(np.diff(e.t) >= 0) and e.t[-1] <= 1e-3
    for contact in (0, 1):  # each contact's transitions alternate, starting with a slip
        kinds = e.kind[e.contact == contact].tolist()
        assert kinds[0] == "slip"
        assert all(a != b for a, b in zip(kinds, kinds[1:]))
    # v* sets the slip threshold (κ = 1): a contact's speed at its transitions is v*.
    for contact, v_star in enumerate(c.v_star):
        np.testing.assert_allclose(e.speed[e.contact == contact], v_star, rtol=1e-3)
    assert run.summary["solver"]["method"] == "dirk"
    assert run.mu == run.summary["mu"] and 0 < run.mu < 20


def test_load_reads_csv_and_hdf5_runs_alike(pair_file, tmp_path):
    case = stickslip.Case.from_toml(pair_file).replace({"output.steps": True})
    csv = stickslip.run(case, out=tmp_path / "csv")
    hdf5 = stickslip.run(case.replace({"output.format": "hdf5"}), out=tmp_path / "hdf5")
    assert (tmp_path / "hdf5" / "run.h5").is_file() and not (tmp_path / "hdf5" / "friction.csv").exists()
    assert hdf5.summary["mu"] == csv.summary["mu"]
    # CSV prints 10 significant digits (12 for t, 15 for event times); HDF5 keeps doubles.
    np.testing.assert_allclose(hdf5.friction.F_f, csv.friction.F_f, rtol=1e-9)
    np.testing.assert_allclose(hdf5.traces.vx, csv.traces.vx, rtol=1e-9, atol=1e-25)
    np.testing.assert_array_equal(hdf5.traces.contact, csv.traces.contact)
    np.testing.assert_allclose(hdf5.events.t, csv.events.t, rtol=1e-14)
    np.testing.assert_array_equal(hdf5.events.kind, csv.events.kind)
    np.testing.assert_array_equal(hdf5.contacts.v_star, csv.contacts.v_star)
    assert set(hdf5.tables) == set(csv.tables) == {"steps"}
    np.testing.assert_allclose(hdf5.tables["steps"]["h"], csv.tables["steps"]["h"], rtol=1e-9)
    with pytest.raises(stickslip.OutputError, match="holds no run"):
        stickslip.load(tmp_path)


SLIP_COLUMNS = ("t_start", "t_end", "duration", "slip", "peak_speed", "load_start", "load_end",
                "load_drop", "F_f_start", "F_f_end", "F_f_drop")


def test_the_slip_catalogue_reads_the_same_from_csv_and_hdf5_and_old_runs_have_none(pair_file, tmp_path):
    case = stickslip.Case.from_toml(pair_file)
    csv = stickslip.run(case, out=tmp_path / "csv")
    hdf5 = stickslip.run(case.replace({"output.format": "hdf5"}), out=tmp_path / "hdf5")
    assert set(stickslip.Slips.__dataclass_fields__) == {"contact", *SLIP_COLUMNS}
    assert len(csv.slips.t_end) == len(hdf5.slips.t_end) >= 2  # each contact's first slip, at least
    np.testing.assert_array_equal(csv.slips.contact, hdf5.slips.contact)
    assert csv.slips.contact.dtype == np.int64
    for name in SLIP_COLUMNS:  # CSV prints 15 digits for the times, 10 for the rest
        rtol = 1e-14 if name.startswith("t_") else 1e-9
        np.testing.assert_allclose(getattr(csv.slips, name), getattr(hdf5.slips, name), rtol=rtol,
                                   err_msg=name)
    # A run written before slips.csv existed loads without it.
    (tmp_path / "csv" / "slips.csv").unlink()
    old = stickslip.load(tmp_path / "csv")
    assert old.slips is None and old.events is not None and "slips" not in old.tables


def test_each_slip_is_its_events_and_what_the_dense_traces_show_in_between(pair_file):
    # Traced every 1e-8 s through the first slip of each contact (~3.4 µs each).
    case = stickslip.Case.from_toml(pair_file).replace(
        {"run.t_end": 8.7e-4, "run.average_from": 1e-4, "output.interval": 1e-8, "output.format": "hdf5"})
    run = stickslip.run(case)
    s, e, tr, f = run.slips, run.events, run.traces, run.friction
    assert sorted(s.contact.tolist()) == [0, 1]
    for i, contact in enumerate(s.contact):
        # Its ends are the contact's slip event and the stick after it, to the bit.
        mine = e.contact == contact
        start = np.flatnonzero(mine & (e.kind == "slip") & (e.t == s.t_start[i]))
        end = np.flatnonzero(mine & (e.kind == "stick") & (e.t == s.t_end[i]))
        assert start.size == end.size == 1
        assert not np.any(mine & (e.t > s.t_start[i]) & (e.t < s.t_end[i]))
        assert s.duration[i] == s.t_end[i] - s.t_start[i]
        # Between them, the traced velocity: the slip is its integral (trapezoids,
        # ends interpolated), the peak at least every traced speed and above
        # their largest by no more than the solution curves between two of them.
        inside = (tr.t > s.t_start[i]) & (tr.t < s.t_end[i])
        k = tr.contact.tolist().index(contact)
        t = np.concatenate(([s.t_start[i]], tr.t[inside], [s.t_end[i]]))
        v = [np.interp(t, tr.t, component[:, k]) for component in (tr.vx, tr.vy)]
        displacement = [np.sum(np.diff(t) * (c[1:] + c[:-1]) / 2) for c in v]
        assert s.slip[i] == pytest.approx(np.hypot(*displacement), rel=1e-4)
        speeds = np.hypot(tr.vx[inside, k], tr.vy[inside, k])
        assert speeds.size > 300
        assert s.peak_speed[i] >= speeds.max()
        assert s.peak_speed[i] <= speeds.max() * (1 + 2e-5)  # curvature ~1e11 m/s³ over 5e-9 s
        # The block's friction at the two events, as friction.csv has it around them.
        assert s.F_f_start[i] == pytest.approx(np.interp(s.t_start[i], f.t, f.F_f), rel=1e-6)
        assert s.F_f_end[i] == pytest.approx(np.interp(s.t_end[i], f.t, f.F_f), rel=1e-6)
        assert s.F_f_drop[i] == s.F_f_start[i] - s.F_f_end[i]
        # The load on a contact as it lets go is what its friction holds at κ v*
        # (inertia apart: measured 2e-4 of it); the slip relieves it.
        assert s.load_start[i] == pytest.approx(e.force[start[0]], rel=1e-2)
        assert 0 < s.load_end[i] < 0.8 * s.load_start[i]
        assert s.load_drop[i] == s.load_start[i] - s.load_end[i]


def test_bad_output_and_failed_runs_raise_the_command_lines_errors(pair_file, tmp_path):
    case = stickslip.Case.from_toml(pair_file)
    stickslip.run(case.replace({"run.t_end": 2e-4, "run.average_from": 1e-4}), out=tmp_path / "r")
    with pytest.raises(stickslip.OutputError, match=r"pass overwrite=True to replace them") as refused:
        stickslip.run(case, out=tmp_path / "r")  # it holds results
    assert "--overwrite" not in str(refused.value)  # the command line's spelling is not Python's
    with pytest.raises(stickslip.OutputError, match="empty path"):
        stickslip.run(case, out="")  # not the working directory
    with pytest.raises(stickslip.IntegrationError):
        stickslip.run(case.replace({"solver.max_steps": 20}))


def test_the_run_releases_the_gil(pair_file):
    case = stickslip.Case.from_toml(pair_file)
    counted, done = [0], threading.Event()

    def count():
        while not done.is_set():
            counted[0] += 1

    counter = threading.Thread(target=count)
    counter.start()
    try:
        before = counted[0]
        stickslip.run(case)
        during = counted[0] - before
    finally:
        done.set()
        counter.join()
    # Held for the whole run, the count would stay put (Python switches threads
    # only between bytecodes): it runs ~1e7 a second.
    assert during > 10_000


INTERRUPTED_RUN = """
import json, sys, stickslip
case = stickslip.Case.from_toml(sys.argv[1])
try:
    stickslip.run(case, out=sys.argv[2] if sys.argv[2] != "-" else None)
except stickslip.Interrupted as stop:
    print(json.dumps({"t": stop.t, "out": None if stop.out is None else str(stop.out), "text": str(stop)}))
    sys.exit(3)
"""


def interrupt_python_run(case_file, out, tmp_path, wait_for):
    """Runs `case_file` through the module in a child Python, SIGINT once `wait_for` exists."""
    env = {**os.environ, "TMPDIR": str(tmp_path / "tmp")}
    (tmp_path / "tmp").mkdir(exist_ok=True)
    child = subprocess.Popen([sys.executable, "-c", INTERRUPTED_RUN, str(case_file), out],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.monotonic() + 60
    while not wait_for() and child.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    child.send_signal(signal.SIGINT)
    stdout, stderr = child.communicate(timeout=60)
    assert child.returncode == 3, stderr
    return stdout


# Seconds, not a fraction of one, so that SIGINT lands mid-run: imex at a tight rtol.
LONG_PAIR = PAIR_TOML.replace("t_end = 1e-3", "t_end = 1.5e-3\ncheckpoint_every = 2e-4") + """
[solver]
method = "imex"
rtol = 1e-7
atol_displacement = 1e-13
atol_velocity = 1e-8
"""


def test_ctrl_c_leaves_a_checkpoint_the_command_line_continues(tmp_path):
    case_file = tmp_path / "long.toml"
    case_file.write_text(LONG_PAIR)
    out = tmp_path / "part"

    stopped = json.loads(interrupt_python_run(case_file, str(out), tmp_path,
                                              lambda: (out / "checkpoint.bin").exists()))
    assert 0 < stopped["t"] < 1.5e-3
    assert stopped["out"] == str(out) and "--restart" in stopped["text"]
    assert not (out / "summary.json").exists()
    cli("run", case_file, "--restart", out, "--quiet")
    cli("run", case_file, "--out", tmp_path / "full", "--quiet")
    part, full = stickslip.load(out), stickslip.load(tmp_path / "full")
    np.testing.assert_array_equal(part.friction.t, full.friction.t)  # no gap, no duplicate
    # A restart changes the step sequence: agreement to the tolerance, as in tests/test_restart.cpp.
    assert abs(part.mu - full.mu) < 1e-5 * abs(full.mu)
    # And the module runs again after an interrupt, from the main thread.
    again = stickslip.run(stickslip.Case.from_toml(case_file).replace({"run.t_end": 1e-4, "run.average_from": 5e-5}))
    assert again.summary is not None


def test_ctrl_c_without_out_keeps_nothing(tmp_path):
    case_file = tmp_path / "long.toml"
    case_file.write_text(LONG_PAIR)
    tmp = tmp_path / "tmp"

    def running():
        return any(tmp.glob("stickslip-run-*/friction.csv"))

    stopped = json.loads(interrupt_python_run(case_file, "-", tmp_path, running))
    assert stopped["out"] is None and "no checkpoint kept" in stopped["text"]
    assert list(tmp.iterdir()) == []



def test_after_a_run_ctrl_c_is_pythons_again(pair_file):
    stickslip.run(stickslip.Case.from_toml(pair_file).replace({"run.t_end": 1e-4, "run.average_from": 5e-5}))
    with pytest.raises(KeyboardInterrupt) as caught:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(1)  # the handler runs at the next bytecode
    assert not isinstance(caught.value, stickslip.Interrupted)


def test_runs_in_threads_at_once_give_the_runs_made_one_by_one(pair_file, capfd):
    from concurrent.futures import ThreadPoolExecutor

    base = stickslip.Case.from_toml(pair_file)
    cases = [base.replace({"drive.velocity": v, "output.format": f})
             for v, f in [(1e-3, "csv"), (7e-4, "hdf5"), (5e-4, "csv"), (3e-4, "hdf5")]]
    one_by_one = [stickslip.run(c) for c in cases]
    with ThreadPoolExecutor(max_workers=4) as pool:  # FFTW's planner and HDF5 shared by all
        at_once = list(pool.map(stickslip.run, cases))
    for a, b in zip(one_by_one, at_once):
        assert a.mu == b.mu
        assert a.summary["solver_stats"] == b.summary["solver_stats"]
        np.testing.assert_array_equal(a.events.t, b.events.t)
        np.testing.assert_array_equal(a.friction.F_f, b.friction.F_f)
    assert "HDF5" not in capfd.readouterr().err  # HDF5 silenced in every thread


def test_load_reads_a_running_run_up_to_its_last_whole_row(pair_file, tmp_path):
    stickslip.run(stickslip.Case.from_toml(pair_file), out=tmp_path / "done")
    running = tmp_path / "running"
    running.mkdir()
    for name in ("contacts.csv", "traces.csv", "events.csv"):
        (running / name).write_bytes((tmp_path / "done" / name).read_bytes())
    rows = (tmp_path / "done" / "friction.csv").read_text().splitlines(keepends=True)
    (running / "friction.csv").write_text("".join(rows[:501]) + rows[501][:9])  # a row being written
    run = stickslip.load(running)
    assert run.summary is None and run.mu is None
    assert run.friction.t.shape == (500,)
    np.testing.assert_array_equal(run.friction.F_f, stickslip.load(tmp_path / "done").friction.F_f[:500])


def test_runs_pickle_for_process_pools(pair_file):
    import pickle
    from concurrent.futures import ProcessPoolExecutor

    case = stickslip.Case.from_toml(pair_file).replace({"run.t_end": 4e-4, "run.average_from": 1e-4})
    run = stickslip.run(case)
    back = pickle.loads(pickle.dumps(run))
    assert back.mu == run.mu
    np.testing.assert_array_equal(back.traces.vx, run.traces.vx)
    with ProcessPoolExecutor(max_workers=1) as pool:  # the case crosses to a worker, the run back
        elsewhere = pool.submit(stickslip.run, case).result()
    assert elsewhere.mu == run.mu
    np.testing.assert_array_equal(elsewhere.traces.vx, run.traces.vx)
    stop = pickle.loads(pickle.dumps(stickslip.Interrupted(2, 1e-4, None)))
    assert isinstance(stop, KeyboardInterrupt) and stop.t == 1e-4 and str(stop).startswith("interrupted at")


THREADED_RUNS = """
import sys, threading, stickslip
from concurrent.futures import ThreadPoolExecutor
case = stickslip.Case.from_toml(sys.argv[1])
outcome = {}
def worker():
    try:
        stickslip.run(case)
        outcome["worker"] = "finished"
    except stickslip.Interrupted:
        outcome["worker"] = "interrupted"
if sys.argv[2] == "main-and-worker":
    thread = threading.Thread(target=worker)
    thread.start()
    try:
        stickslip.run(case)
        outcome["main"] = "finished"
    except stickslip.Interrupted:
        outcome["main"] = "interrupted"
    thread.join()
else:  # a pool, the main thread waiting on it
    try:
        with ThreadPoolExecutor(2) as pool:
            list(pool.map(stickslip.run, [case, case]))
        outcome["pool"] = "finished"
    except stickslip.Interrupted:
        outcome["pool"] = "interrupted"
print(sorted(outcome.items()))
"""


@pytest.mark.parametrize("layout, expected", [
    ("main-and-worker", "[('main', 'interrupted'), ('worker', 'interrupted')]"),
    ("pool", "[('pool', 'interrupted')]"),
])
def test_ctrl_c_stops_every_run_of_the_process(layout, expected, tmp_path):
    case_file = tmp_path / "long.toml"
    case_file.write_text(LONG_PAIR)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = {**os.environ, "TMPDIR": str(tmp)}
    child = subprocess.Popen([sys.executable, "-c", THREADED_RUNS, str(case_file), layout],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.monotonic() + 60
    while len(list(tmp.glob("stickslip-run-*/friction.csv"))) < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    child.send_signal(signal.SIGINT)
    stdout, stderr = child.communicate(timeout=60)
    assert child.returncode == 0, stderr
    assert stdout.strip() == expected
    assert list(tmp.iterdir()) == []  # both temporary directories removed


def test_a_mu_from_the_loading_ramp_is_warned_of_and_flagged():
    # 6x6x4 at coverage 0.5 loads for ~4 ms from rest: a window at [1, 2] ms holds no slip.
    case = {"lattice": {"nx": 6, "ny": 6, "nz": 4}, "interface.coverage": 0.5,
            "run": {"t_end": 2e-3, "average_from": 1e-3}, "output.events": "none"}
    with pytest.warns(stickslip.MuWarning, match="rises as a ramp"):
        run = stickslip.run(case)
    assert run.mu_trusted is False
    assert run.summary["regime"]["kind"] == "loading"
