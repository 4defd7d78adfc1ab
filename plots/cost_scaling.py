#!/usr/bin/python3
"""What a point costs against the lattice's size: wall per simulated ms and
peak memory against the number of nodes, at low and high coverage.

Usage: /usr/bin/python3 plots/cost_scaling.py DIR
  DIR/cost.csv: one row per (lattice, θ): nx, ny, nz, theta, contacts,
  method, wall_per_ms_lo, wall_per_ms_hi (s of wall per simulated ms, one
  core; a range where points differed), memory_MB (peak resident; empty:
  not measured), what (how it was measured).
  -> DIR/cost_scaling.png and .pdf; one line per coverage on stdout: the
     exponent p of wall per ms ∝ nodes^p (least squares on the logs of the
     ranges' midpoints) and the memory per node.
"""
import csv
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _command_line import arguments, directories  # noqa: E402

USAGE = __doc__.split("\n\n", 1)[1]


def fit_exponent(nodes, walls):
    """p and log-intercept of log(wall) = p log(nodes) + b, least squares."""
    x = [math.log(n) for n in nodes]
    y = [math.log(w) for w in walls]
    mx, my = sum(x) / len(x), sum(y) / len(y)
    sxx = sum((a - mx) ** 2 for a in x)
    p = sum((a - mx) * (b - my) for a, b in zip(x, y)) / sxx
    return p, my - p * mx


def main():
    (directory,) = directories(arguments(USAGE, 1, 1))
    table = directory / "cost.csv"
    if not table.is_file():
        print(f"error: {table}: not found", file=sys.stderr)
        raise SystemExit(2)
    rows = list(csv.DictReader(table.open()))
    by_theta = {}
    for r in rows:
        by_theta.setdefault(float(r["theta"]), []).append(r)
    fig, (ax_wall, ax_mem) = plt.subplots(1, 2, figsize=(10, 4))
    for i, (theta, pts) in enumerate(sorted(by_theta.items())):
        pts.sort(key=lambda r: int(r["nx"]) * int(r["ny"]) * int(r["nz"]))
        nodes = [int(r["nx"]) * int(r["ny"]) * int(r["nz"]) for r in pts]
        lo = [float(r["wall_per_ms_lo"]) for r in pts]
        hi = [float(r["wall_per_ms_hi"]) for r in pts]
        mid = [math.sqrt(a * b) for a, b in zip(lo, hi)]
        color = f"C{i}"
        ax_wall.errorbar(nodes, mid, yerr=[[m - a for m, a in zip(mid, lo)], [b - m for m, b in zip(mid, hi)]],
                         marker="o", capsize=3, color=color, label=f"θ = {theta:g}")
        for n, m, r in zip(nodes, mid, pts):
            partial = " (loading only)" if "loading" in r["what"] else ""
            ax_wall.annotate(f"{r['nx']}×{r['ny']}{partial}", (n, m), textcoords="offset points", xytext=(4, -10),
                             fontsize=7, color=color)
        line = f"theta={theta:g}"
        if len(nodes) >= 2:
            p, b = fit_exponent(nodes, mid)
            ends = [nodes[0], nodes[-1]]
            ax_wall.plot(ends, [math.exp(b) * n ** p for n in ends], ls="--", lw=0.8, color=color)
            line += f" wall_per_ms ~ nodes^{p:.2f}"
        mem = [(n, float(r["memory_MB"])) for n, r in zip(nodes, pts) if r["memory_MB"]]
        if mem:
            ax_mem.plot([m[0] for m in mem], [m[1] for m in mem], marker="o", color=color, label=f"θ = {theta:g}")
            largest = max(mem)
            line += f" memory {1e6 * largest[1] / largest[0] / 1024:.2f} KiB/node at {largest[0]} nodes"
        print(line)
    n_ref = [1e3, 3e5]
    ax_wall.plot(n_ref, [2.0 * n / 2250 for n in n_ref], color="gray", lw=0.8, ls=":", label="∝ nodes")
    ax_wall.set(xscale="log", yscale="log", xlabel="lattice nodes (nx·ny·nz)",
                ylabel="wall per simulated ms [s], one core")
    ax_wall.set_title("time (dashed: power-law fit)", fontsize=10)
    ax_wall.legend(fontsize=8)
    ax_wall.grid(alpha=0.3, which="both")
    ax_mem.set(xscale="log", yscale="log", xlabel="lattice nodes (nx·ny·nz)", ylabel="peak memory [MB]")
    ax_mem.set_title("memory", fontsize=10)
    ax_mem.legend(fontsize=8)
    ax_mem.grid(alpha=0.3, which="both")
    fig.suptitle("What a point costs: v = 1e-3 m/s from rest, rtol 1e-5, auto", fontsize=10)
    fig.tight_layout()
    for ext in ("png", "pdf"):
        fig.savefig(directory / f"cost_scaling.{ext}", dpi=110)
    print(f"wrote {directory / 'cost_scaling.png'} and .pdf")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
