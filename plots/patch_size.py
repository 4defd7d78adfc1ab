#!/usr/bin/python3
"""Finite-size asperities (cases/patch_size.toml, MODEL.md §14): how the
block-scale stick-slip changes as each contact grows to an R×R patch of nodes.

Usage: /usr/bin/python3 plots/patch_size.py SWEEP_DIR [SWEEP_DIR...]
       -> the first SWEEP_DIR/patch_size.csv, patch_size.png and .pdf

Reads each SWEEP_DIR/sweep.csv (stickslip sweep) for the finished points and each
point's summary.json for μ over whole cycles of F_f (mu_whole_cycles, μ over
the window where a run has no whole cycle) and F_f_spread (sd/mean of F_f in
the averaging window: the size of the block-scale stick-slip). Per patch size
R and coverage: the mean and sd over seeds. Per R: the drop of μ from the
lowest to the highest coverage, (μ_low − μ_high)/μ_low, with its sd from the
seeds' scatter (propagated, seeds independent at each coverage).

patch_size.csv: R, coverage, theta, n, mu_mean, mu_sd, spread_mean,
spread_sd, drop, drop_sd (drop columns on the highest coverage's rows).
"""
import csv
import json
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from _command_line import arguments, directories  # noqa: E402

COVERAGE = "interface.coverage"


def fail(message: str):
    print(f"error: {message}", file=sys.stderr)
    raise SystemExit(2)


def mean_sd(xs):
    m = sum(xs) / len(xs)
    sd = math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1)) if len(xs) > 1 else 0.0
    return m, sd


def read_points(sweep_dir: Path):
    """[(R, coverage, theta, mu, spread)] of the finished points, and the set of
    (nx/R, ny/R, nz/R, v) they share (for the title)."""
    table = sweep_dir / "sweep.csv"
    if not table.is_file():
        fail(f"{table}: not found (run `stickslip sweep cases/patch_size.toml` first)")
    with table.open() as f:
        rows = list(csv.DictReader(f))
    if not rows or COVERAGE not in rows[0]:
        fail(f"{table}: the sweep does not vary {COVERAGE}")
    points, shapes = [], set()
    for r in rows:
        if r.get("status") != "finished":
            continue
        summary_file = sweep_dir / r["point"] / "summary.json"
        if not summary_file.is_file():
            fail(f"{summary_file}: not found, though {table} says the point finished")
        s = json.loads(summary_file.read_text())
        if "F_f_spread" not in s:
            fail(f"{summary_file}: no F_f_spread (written by a version older than the patch study)")
        case = s["case"]
        patch = int(case["interface"].get("patch", 1))
        lattice = case["lattice"]
        shapes.add((lattice["nx"] / patch, lattice["ny"] / patch, lattice["nz"] / patch,
                    case["drive"]["velocity"]))
        cycles = s.get("mu_whole_cycles")
        mu = cycles["mu"] if cycles else s["mu"]
        points.append((patch, float(r[COVERAGE]), s["theta"], mu, s["F_f_spread"]))
    if not points:
        fail(f"{table}: no finished point")
    return points, shapes


def tabulate(points):
    """{R: {coverage: (theta, n, mu, mu_sd, spread, spread_sd)}}"""
    groups = {}
    for patch, coverage, theta, mu, spread in points:
        groups.setdefault(patch, {}).setdefault(coverage, []).append((theta, mu, spread))
    table = {}
    for patch, by_coverage in groups.items():
        for coverage, pts in by_coverage.items():
            theta = sum(p[0] for p in pts) / len(pts)
            mu, mu_sd = mean_sd([p[1] for p in pts])
            spread, spread_sd = mean_sd([p[2] for p in pts])
            table.setdefault(patch, {})[coverage] = (theta, len(pts), mu, mu_sd, spread, spread_sd)
    return table


def drop(by_coverage):
    """(μ_low − μ_high)/μ_low and its sd, or None with fewer than two coverages."""
    if len(by_coverage) < 2:
        return None
    low, high = by_coverage[min(by_coverage)], by_coverage[max(by_coverage)]
    (_, n_lo, mu_lo, sd_lo, _, _), (_, n_hi, mu_hi, sd_hi, _, _) = low, high
    d = (mu_lo - mu_hi) / mu_lo
    # d = 1 - mu_hi/mu_lo: relative errors of the two means add in quadrature.
    rel = math.hypot(sd_lo / math.sqrt(n_lo) / mu_lo, sd_hi / math.sqrt(n_hi) / mu_hi)
    return d, (mu_hi / mu_lo) * rel


def main() -> int:
    sweep_dirs = directories(arguments(__doc__, 1))
    sweep_dir = sweep_dirs[0]
    points, shapes = [], set()
    for d in sweep_dirs:
        more, more_shapes = read_points(d)
        points += more
        shapes |= more_shapes
    table = tabulate(points)
    sizes = sorted(table)
    coverages = sorted({c for by_c in table.values() for c in by_c})

    with (sweep_dir / "patch_size.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["R", "coverage", "theta", "n", "mu_mean", "mu_sd", "spread_mean", "spread_sd",
                    "drop", "drop_sd"])
        for patch in sizes:
            d = drop(table[patch])
            for coverage in sorted(table[patch]):
                theta, n, mu, mu_sd, spread, spread_sd = table[patch][coverage]
                last = coverage == max(table[patch]) and d is not None
                w.writerow([patch, coverage, f"{theta:.6g}", n, f"{mu:.8g}", f"{mu_sd:.4g}",
                            f"{spread:.6g}", f"{spread_sd:.4g}",
                            f"{d[0]:.6g}" if last else "", f"{d[1]:.4g}" if last else ""])
                print(f"R={patch} coverage={coverage:g} theta={theta:.4g} n={n} mu_mean={mu:.6g} "
                      f"mu_sd={mu_sd:.3g} spread_mean={spread:.4g} spread_sd={spread_sd:.3g}")
            if d is not None:
                print(f"R={patch} drop={d[0]:.4g} drop_sd={d[1]:.3g}")

    fig, (ax_mu, ax_spread, ax_drop) = plt.subplots(1, 3, figsize=(11, 3.6))
    for i, coverage in enumerate(coverages):
        rs = [r for r in sizes if coverage in table[r]]
        rows = [table[r][coverage] for r in rs]
        theta = sum(row[0] for row in rows) / len(rows)
        style = dict(marker="o", ms=4, capsize=3, lw=1, color=f"C{i}", label=f"θ ≈ {theta:.3g}")
        ax_mu.errorbar(rs, [row[2] for row in rows], yerr=[row[3] for row in rows], **style)
        ax_spread.errorbar(rs, [row[4] for row in rows], yerr=[row[5] for row in rows], **style)
    drops = [(r, drop(table[r])) for r in sizes if drop(table[r]) is not None]
    if drops:
        ax_drop.errorbar([r for r, _ in drops], [100 * d[0] for _, d in drops],
                         yerr=[100 * d[1] for _, d in drops], marker="o", ms=4, capsize=3, lw=1, color="k")
    ax_drop.axhline(0, color="0.6", lw=0.8)
    ax_mu.set_ylabel("μ over whole cycles of $F_f$")
    ax_spread.set_ylabel("sd/mean of $F_f$ in the window")
    ax_drop.set_ylabel(f"drop of μ, θ {coverages[0]:g} → {coverages[-1]:g} [%]")
    for ax in (ax_mu, ax_spread, ax_drop):
        ax.set_xlabel("patch size R [nodes per side]")
        ax.set_xticks(sizes)
        ax.grid(alpha=0.3)
    ax_mu.legend(fontsize=8)
    ax_spread.legend(fontsize=8)
    title = "Finite-size asperities: R×R patches"
    if len(shapes) == 1:
        nx, ny, nz, v = next(iter(shapes))
        title += f", lattice {nx:g}R×{ny:g}R×{nz:g}R, v = {v:g} m/s"
    fig.suptitle(title + " (mean ± sd over seeds)", fontsize=10)
    fig.tight_layout()
    for ext in ("png", "pdf"):
        fig.savefig(sweep_dir / f"patch_size.{ext}", dpi=130)
    print(f"wrote {sweep_dir / 'patch_size.csv'}, {sweep_dir / 'patch_size.png'} and .pdf")
    return 0


if __name__ == "__main__":
    sys.exit(main())
