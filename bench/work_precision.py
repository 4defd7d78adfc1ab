#!/usr/bin/python3
"""Work-precision runs: wall time against error for each method and tolerance
(or fixed step), every run compared with a reference solution.

Usage:
  /usr/bin/python3 bench/work_precision.py CASE.toml [--out DIR] [--exe build/stickslip]
      [--methods imex,erk,dirk,bdf,multirate] [--rtols 1e-3,...,1e-9]
      [--method-rtols imex=1e-5,1e-6] [--imex-steps 1e-7,5e-8,2e-8]
      [--rk4-steps 1e-13] [--repeats 3] [--ref-rtol 1e-10] [--state-horizon T]
      [--set KEY=VALUE ...] [--floor 1e-12] [--timeout 600] [--append]

The reference is --ref-method at --ref-rtol (absolute tolerances follow rtol), cached
in DIR/reference and reused only if it was computed by the same code version
for the same case. Every other run gets [solver] audit_bound = 1e9 so that a
poor run still reports the μ whose error is measured (its energy residual is
in the table). A run still going after --timeout seconds is stopped (SIGTERM:
it checkpoints and exits); its row records how far it got and the wall time
that pace extrapolates to the whole horizon, and it is not repeated.

With --state-horizon T every setting is also run to t_end = T with
[output] final_state, against a reference to T: the final-state error is the
relative L2 norm of the state difference, displacements weighted by 1/(1 µs)
so that they count like the velocities (one lattice period is ~1 µs).

--set KEY=VALUE (repeatable) is passed to every run, the reference's and the
probe's included (and is part of the reference's cache key): e.g. to shorten a
case, `--set run.t_end=15e-3`.

With --floor REL the reference is run a second time with drive.velocity
multiplied by 1 + REL (1e-12: the last digits of the input) and compared with
the reference like any other run; its row (method "floor", setting
"dv=REL") is the chaos floor: where the dynamics are chaotic (many contacts
slipping in bursts) no run can be compared with the reference more closely
than this, and errors below it mean nothing.

DIR/meta.json records the command line, the code version, the case, the
method `auto` chooses for it and the default rtol (from a one-step probe run
with the case's own solver settings), for plots/work_precision.py.

Writes DIR/work_precision.csv, one row per run: method, setting, wall time
(median of repeats), CPU time (user + system), peak memory, steps, rhs evaluations, energy residual, and
the errors from `stickslip compare`: μ relative error, largest relative L2
trace error, largest event-time error, unmatched events; and the final-state
error. Plot with plots/work_precision.py DIR.
"""
import argparse
import csv
import hashlib
import json
import math
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run(exe, case, out, sets, repeats, timeout):
    """Runs the case up to `repeats` times into `out`.

    Returns a dict: wall (median s), cpu (user + system s of that median
    run; on a busy machine it says how much of the wall time was waiting),
    peak_kb, status (finished, failed, timeout), message."""
    walls, cpus, peak = [], [], 0
    for _ in range(repeats):
        cmd = [exe, "run", str(case), "--out", str(out), "--overwrite", "--quiet"]
        for s in sets:
            cmd += ["--set", s]
        # stderr goes to a file: a pipe read only at the end would block a run
        # that writes more than the pipe holds (solver warnings).
        with tempfile.TemporaryFile(mode="w+") as stderr:
            start = time.perf_counter()
            proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=stderr, text=True)
            deadline = start + timeout
            timed_out = False
            while True:
                pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
                if pid:
                    break
                now = time.perf_counter()
                if now > deadline and not timed_out:
                    proc.send_signal(signal.SIGTERM)
                    timed_out = True
                elif timed_out and now > deadline + 300:
                    proc.kill()  # it did not answer its stop request
                time.sleep(0.05)
            walls.append(time.perf_counter() - start)
            cpus.append(usage.ru_utime + usage.ru_stime)
            peak = max(peak, usage.ru_maxrss)
            stderr.seek(0)
            err = stderr.read().strip()
        if timed_out:
            # "interrupted at t = ... s; ..." says how far it got.
            m = re.search(r"interrupted at t = ([0-9.eE+-]+) s", err)
            return {"wall": walls[-1], "cpu": cpus[-1], "peak_kb": peak, "status": "timeout",
                    "t_reached": float(m.group(1)) if m else 0.0,
                    "message": f"stopped after {timeout:g} s"}
        if os.waitstatus_to_exitcode(status) != 0:
            return {"wall": statistics.median(walls), "cpu": cpus[-1], "peak_kb": peak, "status": "failed",
                    "message": err.splitlines()[-1] if err else "failed"}
    median = sorted(range(len(walls)), key=lambda i: walls[i])[len(walls) // 2]
    return {"wall": statistics.median(walls), "cpu": cpus[median], "peak_kb": peak, "status": "finished", "message": ""}


def compare(exe, ref, out):
    report = out / "compare.json"
    subprocess.run([exe, "compare", str(ref), str(out), "--out", str(report)],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    r = json.loads(report.read_text())
    rel_l2 = [c["rel_l2"] for c in r["traces"]["columns"] if c["rel_l2"] is not None]
    dts = [g["max_dt"] for g in r["events"]["groups"] if g["max_dt"] is not None]
    unmatched = sum(g["unmatched_a"] + g["unmatched_b"] for g in r["events"]["groups"])
    return {
        "mu_error": r["mu"]["rel_diff"],
        "trace_error": max(rel_l2) if rel_l2 else "",
        "event_error": max(dts) if dts else "",
        "unmatched_events": unmatched,
    }


def read_state(directory):
    with open(directory / "final_state.csv") as f:
        rows = list(csv.reader(f))[1:]
    return [[float(x) for x in r[4:]] for r in rows]


def state_error(ref_dir, run_dir):
    """Relative L2 error of the final state, displacements weighted by 1e6 s⁻¹."""
    ref, got = read_state(ref_dir), read_state(run_dir)
    num = den = 0.0
    for a, b in zip(got, ref):
        for k in range(6):
            w = 1e6 if k < 3 else 1.0
            num += (w * (a[k] - b[k])) ** 2
            den += (w * b[k]) ** 2
    return math.sqrt(num / den)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("case", type=Path)
    p.add_argument("--out", type=Path)
    p.add_argument("--exe", default=str(Path(__file__).resolve().parent.parent / "build" / "stickslip"))
    p.add_argument("--rtols", default="1e-4,1e-5,1e-6,1e-7")
    p.add_argument("--imex-steps", default="")
    p.add_argument("--dirk-steps", default="")
    p.add_argument("--rk4-steps", default="")
    p.add_argument("--ref-method", default="dirk")  # imex at 1e-9 takes ~5e-9 s steps in the creep
    p.add_argument("--methods", default="imex", help="adaptive methods, comma-separated")
    p.add_argument("--method-rtols", action="append", default=[], metavar="METHOD=R1,R2",
                   help="this method's tolerances instead of --rtols (repeatable)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                   help="passed to every run, the reference's included (repeatable)")
    p.add_argument("--floor", type=float, default=0.0,
                   help="also run the reference with drive.velocity × (1 + FLOOR): the chaos floor row")
    p.add_argument("--repeats", type=int, default=1)
    p.add_argument("--ref-rtol", type=float, default=1e-9)
    p.add_argument("--state-horizon", type=float, default=0.0)
    p.add_argument("--timeout", type=float, default=600.0, help="seconds per run")
    p.add_argument("--rk4-timeout", type=float, default=120.0,
                   help="seconds per rk4 run: enough to measure its pace, which is extrapolated")
    p.add_argument("--append", action="store_true",
                   help="keep the rows already in DIR/work_precision.csv (a row of the same method "
                        "and setting is replaced)")
    a = p.parse_args()
    if not a.case.is_file():
        print(f"error: {a.case}: no such case file", file=sys.stderr)
        return 2
    out = a.out or Path("out") / ("wp_" + a.case.stem)
    out.mkdir(parents=True, exist_ok=True)
    # A one-step probe run tells the code version and that the case runs.
    probe_dir = out / "probe"
    common = [x for s in a.sets for x in ("--set", s)]
    pr = subprocess.run([a.exe, "run", str(a.case), "--out", str(probe_dir), "--overwrite", "--quiet"]
                        + common + ["--set", "run.t_end=1e-12", "--set", "run.average_from=0"],
                        capture_output=True, text=True)
    if pr.returncode != 0:
        print(f"error: {a.case}: does not run: {pr.stderr.strip()}", file=sys.stderr)
        return 2
    probe = json.loads((probe_dir / "summary.json").read_text())
    case_hash = hashlib.sha256(a.case.read_bytes()).hexdigest()
    (out / "meta.json").write_text(json.dumps({
        "command": sys.argv, "case": str(a.case), "case_sha256": case_hash,
        "git_commit": probe["provenance"]["git_commit"], "sets": a.sets,
        "auto_method": probe["solver"]["method"], "auto_chosen_by": probe["solver"].get("chosen_by", ""),
        "default_rtol": probe["solver"]["rtol"], "ref_method": a.ref_method, "ref_rtol": a.ref_rtol,
        "floor": a.floor}, indent=1) + "\n")

    def scaled(rtol):  # the absolute tolerances follow rtol (src/integrate/tolerances.cpp)
        return [f"solver.rtol={rtol:g}"]

    def reference(name, extra):
        """Runs the reference into out/name, or reuses the one there if it was
        made by this code version from this case file with the same settings."""
        ref = out / name
        sets = a.sets + [f"solver.method=\"{a.ref_method}\""] + scaled(a.ref_rtol) + extra
        key = {"git_commit": probe["provenance"]["git_commit"], "case_sha256": case_hash, "sets": sets}
        key_file = out / f"{name}.key.json"
        if (ref / "summary.json").is_file() and key_file.is_file() and json.loads(key_file.read_text()) == key:
            return ref
        print(f"{name}: {a.ref_method} rtol {a.ref_rtol:g} ...", flush=True)
        r = run(a.exe, a.case, ref, sets, 1, 1e9)
        if r["status"] != "finished":
            print(f"error: the reference run failed: {r['message']}", file=sys.stderr)
            return None
        key_file.write_text(json.dumps(key))
        print(f"  {r['wall']:.1f} s", flush=True)
        return ref

    ref = reference("reference", [])
    if ref is None:
        return 1
    case_t_end = json.loads((ref / "summary.json").read_text())["t_end"]
    state_ref, horizon = None, a.state_horizon
    if horizon > 0:
        state_ref = reference("reference_state", [f"run.t_end={horizon:g}", "run.average_from=0",
                                                  "output.final_state=true", "output.events=\"none\""])
        if state_ref is None:
            return 1

    floor_dir = None
    if a.floor > 0:
        v = probe["case"]["drive"]["velocity"]
        floor_dir = reference("reference_floor", [f"drive.velocity={v * (1 + a.floor)!r}"])
        if floor_dir is None:
            return 1

    meta = json.loads((out / "meta.json").read_text())
    for key, d in (("reference", ref), ("reference_floor", floor_dir)):
        if d is not None:
            s = json.loads((d / "summary.json").read_text())
            meta[key] = {"wall_seconds": s["wall_seconds"], "steps": s["solver_stats"]["steps"], "mu": s["mu"],
                         "drive_velocity": s["case"]["drive"]["velocity"]}
    (out / "meta.json").write_text(json.dumps(meta, indent=1) + "\n")

    own_rtols = dict(x.split("=", 1) for x in a.method_rtols)
    plan = []
    for m in [x for x in a.methods.split(",") if x]:
        for r in [float(x) for x in own_rtols.get(m, a.rtols).split(",") if x]:
            plan.append((m, f"rtol={r:g}", [f"solver.method=\"{m}\""] + scaled(r)))
    for h in [float(x) for x in a.imex_steps.split(",") if x]:
        plan.append(("imex-fixed", f"step={h:g}", ["solver.method=\"imex\"", f"solver.step={h:g}"]))
    for h in [float(x) for x in a.dirk_steps.split(",") if x]:
        plan.append(("dirk-fixed", f"step={h:g}", ["solver.method=\"dirk\"", f"solver.step={h:g}"]))
    for h in [float(x) for x in a.rk4_steps.split(",") if x]:
        plan.append(("rk4", f"step={h:g}", ["solver.method=\"rk4\"", f"solver.step={h:g}"]))

    rows = []
    table = out / "work_precision.csv"
    if a.append and table.is_file():
        planned = {(m, st) for m, st, _ in plan}
        with table.open() as f:
            rows = [r for r in csv.DictReader(f) if (r["method"], r["setting"]) not in planned]
    if floor_dir is not None:
        rows = [r for r in rows if r["method"] != "floor"]
        s = json.loads((floor_dir / "summary.json").read_text())
        st = s["solver_stats"]
        row = {"method": "floor", "setting": f"dv={a.floor:g}", "status": "finished",
               "wall_seconds": f"{s['wall_seconds']:.3f}", "steps": st["steps"],
               "rhs_explicit": st["rhs_explicit"], "rhs_implicit": st["rhs_implicit"],
               "energy_residual": s["energy_residual"], "mu": s["mu"],
               "message": f"the reference with drive.velocity × (1 + {a.floor:g})",
               **compare(a.exe, ref, floor_dir)}
        rows.append(row)
        print(f"floor      dv={a.floor:g}  mu error {row['mu_error']}  event error {row['event_error']}"
              f"  trace error {row['trace_error']}", flush=True)
        write_table(out, rows)
    for method, setting, sets in plan:
        d = out / f"{method}_{setting.replace('=', '')}"
        timeout = a.rk4_timeout if method == "rk4" else a.timeout
        r = run(a.exe, a.case, d, a.sets + sets + ["solver.audit_bound=1e9"], a.repeats, timeout)
        row = {"method": method, "setting": setting, "wall_seconds": f"{r['wall']:.3f}",
               "cpu_seconds": f"{r['cpu']:.3f}",
               "peak_rss_kb": r["peak_kb"], "status": r["status"], "message": r["message"]}
        if r["status"] == "finished":
            s = json.loads((d / "summary.json").read_text())
            st = s["solver_stats"]
            row.update(steps=st["steps"], rhs_explicit=st["rhs_explicit"], rhs_implicit=st["rhs_implicit"],
                       energy_residual=s["energy_residual"], mu=s["mu"], **compare(a.exe, ref, d))
        elif r["status"] == "timeout":
            reached = r["t_reached"]
            row["t_reached"] = reached
            if reached > 0:
                row["extrapolated_wall_seconds"] = f"{r['wall'] * case_t_end / reached:.4g}"
        if state_ref is not None and r["status"] == "finished":
            ds = out / f"{method}_{setting.replace('=', '')}_state"
            rs = run(a.exe, a.case, ds, a.sets + sets + ["solver.audit_bound=1e9", f"run.t_end={horizon:g}",
                                                "run.average_from=0", "output.final_state=true",
                                                "output.events=\"none\""], 1, timeout)
            if rs["status"] == "finished":
                row["state_error"] = state_error(state_ref, ds)
                row["state_wall_seconds"] = f"{rs['wall']:.3f}"
        rows.append(row)
        print(f"{method:10s} {setting:14s} {row['status']:8s} {r['wall']:8.2f} s  mu error {row.get('mu_error', '-')}"
              f"  event error {row.get('event_error', '-')}  state error {row.get('state_error', '-')}"
              f"  {row.get('extrapolated_wall_seconds', '')}", flush=True)
        write_table(out, rows)
    print(f"wrote {out / 'work_precision.csv'}")
    return 0


FIELDS = ["method", "setting", "status", "wall_seconds", "cpu_seconds", "peak_rss_kb", "steps", "rhs_explicit",
          "rhs_implicit", "energy_residual", "mu", "mu_error", "trace_error", "event_error",
          "unmatched_events", "state_error", "state_wall_seconds", "t_reached",
          "extrapolated_wall_seconds", "message"]


def write_table(out, rows):
    with (out / "work_precision.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in FIELDS})


if __name__ == "__main__":
    sys.exit(main())
