#!/usr/bin/python3
"""Tables from build/bench/stickslip_block_slip's JSON outputs.

Usage:
  /usr/bin/python3 bench/block_slip_table.py errors REFERENCE.json RUN.json...
  /usr/bin/python3 bench/block_slip_table.py spread RUN.json...

`errors`: each run against the reference (CSV on stdout): first-slip times
(largest |Δt|), peak speeds of the contacts that slipped (largest relative
error), the contacts' speeds at the window's end (relative L2) and the
friction force at the end (relative). For a window that the runs follow
trajectory for trajectory (the creep and lone slips before a block slip).

`spread`: per run, what a block slip is made of, for windows where no
trajectory is reproducible (the block slip's nucleation amplifies any
difference, numerical or physical; docs/notes/performance-history.md, "Multirate"): when the
block slip nucleates (the first slip after the window's first two lone
slips, counted from the window's start, µs), its slip events, the median
peak speed of the contacts that slipped, and the friction force at the end.
"""
import json
import math
import statistics
import sys


def load(path):
    with open(path) as f:
        return json.load(f)


def stats_columns(d):
    s = d["stats"]
    return [d["method"], f"{d['rtol']:g}", f"{d['wall']:.3g}", s["steps"], s["step_attempts"],
            s.get("coupling_iterations", 0), s.get("substeps", 0)]


def errors(ref_path, paths):
    ref = load(ref_path)
    print("method,rtol,wall_s,steps,step_attempts,coupling_iterations,substeps,slip_events,"
          "first_slip_max_dt_s,peak_speed_max_rel,end_speed_rel_l2,F_f_end_rel")
    for p in paths:
        d = load(p)
        dt = [abs(a - b) for a, b in zip(d["first_slip"], ref["first_slip"])
              if a is not None and b is not None]
        unmatched = sum((a is None) != (b is None) for a, b in zip(d["first_slip"], ref["first_slip"]))
        if unmatched:
            print(f"{p}: {unmatched} contacts slip in only one of the runs", file=sys.stderr)
        peak = [abs(a / b - 1) for a, b, n in zip(d["peak_speed"], ref["peak_speed"], ref["slips"]) if n > 0]
        end = math.sqrt(sum((a - b) ** 2 for a, b in zip(d["end_speed"], ref["end_speed"])) /
                        sum(b * b for b in ref["end_speed"]))
        row = stats_columns(d) + [sum(d["slips"]), f"{max(dt) if dt else 0:.2e}",
                                  f"{max(peak) if peak else 0:.2e}", f"{end:.2e}",
                                  f"{d['friction_force_end'] / ref['friction_force_end'] - 1:+.2e}"]
        print(",".join(str(x) for x in row))


def spread(paths):
    print("method,rtol,wall_s,steps,step_attempts,coupling_iterations,substeps,slip_events,"
          "nucleation_us,median_peak_speed,F_f_end_N")
    for p in paths:
        d = load(p)
        first = sorted(t for t in d["first_slip"] if t is not None)
        nucleation = (first[2] - d["t0"]) * 1e6 if len(first) > 2 else float("nan")
        peaks = [v for v, n in zip(d["peak_speed"], d["slips"]) if n > 0]
        row = stats_columns(d) + [sum(d["slips"]), f"{nucleation:.2f}",
                                  f"{statistics.median(peaks):.4g}", f"{d['friction_force_end']:.4g}"]
        print(",".join(str(x) for x in row))


if __name__ == "__main__":
    if len(sys.argv) < 3 or sys.argv[1] not in ("errors", "spread"):
        sys.exit(__doc__)
    if sys.argv[1] == "errors":
        errors(sys.argv[2], sys.argv[3:])
    else:
        spread(sys.argv[2:])
