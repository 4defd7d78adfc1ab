#!/usr/bin/python3
"""Work-precision runs: wall time against error for each method and tolerance
(or fixed step), every run compared with a reference solution.

Usage:
  /usr/bin/python3 bench/work_precision.py CASE.toml [--out DIR] [--exe build/stickslip]
      [--rtols 1e-4,1e-5,1e-6,1e-7] [--imex-steps 5e-8,2e-8] [--rk4-steps 1e-13]
      [--methods imex] [--repeats 1] [--ref-rtol 1e-9]

The reference is imex at --ref-rtol (atol scaled alike), cached in
DIR/reference and reused only if it was computed by the same code version for
the same case. Every other run gets [solver] audit_bound = 1e9 so that a
poor run still reports the μ whose error is measured (its energy residual is
in the table). Writes DIR/work_precision.csv, one row per run: method,
setting, wall time (median of repeats), peak memory, steps, rhs evaluations,
energy residual, and the errors against the reference from `stickslip
compare`: μ relative error, largest relative L2 trace error, largest event
time error, unmatched events. Plot with plots/work_precision.py DIR.
"""
import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path


def run(exe, case, out, sets, repeats):
    """Runs the case `repeats` times into `out`; returns (median wall s, peak RSS kB, ok, message)."""
    walls, peak = [], 0
    for _ in range(repeats):
        cmd = [exe, "run", str(case), "--out", str(out), "--overwrite", "--quiet"]
        for s in sets:
            cmd += ["--set", s]
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        _, status, usage = os.wait4(proc.pid, 0)
        walls.append(time.perf_counter() - start)
        peak = max(peak, usage.ru_maxrss)
        err = proc.stderr.read().strip()
        proc.stdout.read()
        if os.waitstatus_to_exitcode(status) != 0:
            return statistics.median(walls), peak, False, err.splitlines()[-1] if err else "failed"
    return statistics.median(walls), peak, True, ""


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


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("case", type=Path)
    p.add_argument("--out", type=Path)
    p.add_argument("--exe", default=str(Path(__file__).resolve().parent.parent / "build" / "stickslip"))
    p.add_argument("--rtols", default="1e-4,1e-5,1e-6,1e-7")
    p.add_argument("--imex-steps", default="")
    p.add_argument("--rk4-steps", default="")
    p.add_argument("--methods", default="imex", help="adaptive methods, comma-separated")
    p.add_argument("--repeats", type=int, default=1)
    p.add_argument("--ref-rtol", type=float, default=1e-9)
    a = p.parse_args()
    if not a.case.is_file():
        print(f"error: {a.case}: no such case file", file=sys.stderr)
        return 2
    out = a.out or Path("out") / ("wp_" + a.case.stem)
    out.mkdir(parents=True, exist_ok=True)

    def scaled(rtol):  # absolute tolerances scaled with rtol from the defaults
        f = rtol / 1e-6
        return [f"solver.rtol={rtol:g}", f"solver.atol_displacement={1e-12 * f:g}",
                f"solver.atol_velocity={1e-7 * f:g}"]

    ref = out / "reference"
    ref_sets = scaled(a.ref_rtol) + ["output.traces=\"all\""]
    cached = False
    if (ref / "summary.json").is_file():
        # Reused only for the same case and code: a 1-step probe run tells the current version.
        probe = out / "probe"
        subprocess.run([a.exe, "run", str(a.case), "--out", str(probe), "--overwrite", "--quiet",
                        "--set", "run.t_end=1e-12", "--set", "run.average_from=0"],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        s_ref = json.loads((ref / "summary.json").read_text())
        s_probe = json.loads((probe / "summary.json").read_text())
        same_code = s_ref["provenance"]["git_commit"] == s_probe["provenance"]["git_commit"]
        c_ref, c_probe = dict(s_ref["case"]), dict(s_probe["case"])
        for c in (c_ref, c_probe):
            c.pop("run", None), c.pop("solver", None), c.pop("output", None), c.pop("source", None)
        cached = same_code and c_ref == c_probe and s_ref["case"]["solver"]["rtol"] == a.ref_rtol
    if not cached:
        print(f"reference: imex rtol {a.ref_rtol:g} ...", flush=True)
        wall, _, ok, msg = run(a.exe, a.case, ref, ref_sets, 1)
        if not ok:
            print(f"error: the reference run failed: {msg}", file=sys.stderr)
            return 1
        print(f"  {wall:.1f} s", flush=True)

    plan = []
    for m in a.methods.split(","):
        for r in [float(x) for x in a.rtols.split(",") if x]:
            plan.append((m, f"rtol={r:g}", [f"solver.method=\"{m}\""] + scaled(r)))
    for h in [float(x) for x in a.imex_steps.split(",") if x]:
        plan.append(("imex-fixed", f"step={h:g}", ["solver.method=\"imex\"", f"solver.step={h:g}"]))
    for h in [float(x) for x in a.rk4_steps.split(",") if x]:
        plan.append(("rk4", f"step={h:g}", ["solver.method=\"rk4\"", f"solver.step={h:g}"]))

    rows = []
    for method, setting, sets in plan:
        d = out / f"{method}_{setting.replace('=', '')}"
        wall, peak, ok, msg = run(a.exe, a.case, d, sets + ["output.traces=\"all\"", "solver.audit_bound=1e9"],
                                  a.repeats)
        row = {"method": method, "setting": setting, "wall_seconds": f"{wall:.3f}", "peak_rss_kb": peak,
               "status": "finished" if ok else "failed", "message": msg}
        if ok:
            s = json.loads((d / "summary.json").read_text())
            st = s["solver_stats"]
            row.update(steps=st["steps"], rhs_explicit=st["rhs_explicit"], rhs_implicit=st["rhs_implicit"],
                       energy_residual=s["energy_residual"], mu=s["mu"], **compare(a.exe, ref, d))
        rows.append(row)
        print(f"{method:10s} {setting:14s} {row['status']:8s} {wall:8.2f} s  mu error {row.get('mu_error', '-')}"
              f"  event error {row.get('event_error', '-')}", flush=True)

    fields = ["method", "setting", "status", "wall_seconds", "peak_rss_kb", "steps", "rhs_explicit",
              "rhs_implicit", "energy_residual", "mu", "mu_error", "trace_error", "event_error",
              "unmatched_events", "message"]
    with (out / "work_precision.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in fields})
    print(f"wrote {out / 'work_precision.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
