#!/usr/bin/python3
"""Does μ's drop with load survive as the block grows? The drop
1 − μ(0.498)/μ(0.04) against 1/L (L = Nx = Ny), with its error over seeds, and
a straight-line extrapolation to L → ∞ where three or more widths have a drop
with an error. Beside it, the other reading of the same points: a drop that
vanishes slowly, a L^−p (a power law, fitted the same way). Both are drawn,
with their χ², and each one's drop at twice the widest L, where a run would
weigh them. A lattice with one seed at a load takes that load's error from
the seeds' spread on the next narrower lattice (hollow marker, "(assumed)" in
the table).

Usage: /usr/bin/python3 plots/finite_size.py SWEEP_DIR
       (the output of `stickslip sweep cases/finite_size.toml`)
  -> SWEEP_DIR/finite_size.png, finite_size.pdf and finite_size.csv (one row
     per lattice and coverage: seeds, μ over whole cycles with its standard
     error, F_f's spread, the block-scale cycle's period; then one row per
     lattice with the drop and its propagated error, then each model's
     limit and its drop at twice the widest L)

μ of a point is μ over whole cycles of F_f (summary.json's mu_whole_cycles),
else over the window. The period is (to − from)/(block_slips − 1) of the whole
cycles, between the block slips the run found (older summaries: crossings of
the window mean, meaningless where many small slips cross it, θ = 0.04).
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
import numpy as np  # noqa: E402
from scipy.optimize import curve_fit  # noqa: E402

LOW, HIGH = 0.04, 0.498


def points(sweep_dir: Path):
    """One dict per finished point: lattice, coverage, seed, μ, spread, period, cost."""
    out = []
    for summary in sorted(sweep_dir.glob("*/summary.json")):
        try:
            s = json.loads(summary.read_text())
        except (OSError, ValueError):
            continue  # a point still running, or cut short
        case = s["case"]
        cycles = s.get("mu_whole_cycles")
        period = None
        # Cycles between block slips; an older summary counted crossings of the mean.
        bounds = (cycles.get("block_slips") or cycles.get("crossings") or 0) if cycles else 0
        if bounds >= 2:
            period = (cycles["to"] - cycles["from"]) / (bounds - 1)
        out.append({
            "nx": case["lattice"]["nx"], "ny": case["lattice"]["ny"], "nz": case["lattice"]["nz"],
            "coverage": case["interface"]["coverage"], "seed": case["interface"]["seed"],
            "mu": cycles["mu"] if cycles else s["mu"], "whole_cycles": bool(cycles),
            "spread": s.get("F_f_spread"), "period": period, "cycles": bounds - 1 if bounds >= 2 else 0,
            "wall_hours": s["wall_seconds"] / 3600, "contacts": s["contacts"],
        })
    return out


def mean_sem(values):
    n = len(values)
    m = sum(values) / n
    if n < 2:
        return m, None, None
    sd = math.sqrt(sum((v - m) ** 2 for v in values) / (n - 1))
    return m, sd, sd / math.sqrt(n)


def main() -> int:
    (sweep_dir,) = directories(arguments(__doc__, 1, 1))
    pts = points(sweep_dir)
    if not pts:
        raise SystemExit(f"error: {sweep_dir}: no finished point (no */summary.json)")
    groups = {}
    for p in pts:
        groups.setdefault((p["nx"], p["ny"], p["nz"], p["coverage"]), []).append(p)

    rows, drops, seeds = [], [], {}
    lattices = sorted({k[:3] for k in groups})
    spread = {}  # (nz, θ) -> the s.d. over seeds of the widest lattice so far that has one
    for lat in lattices:
        stats = {}
        assumed = False
        for theta in (LOW, HIGH):
            g = groups.get(lat + (theta,))
            if not g:
                continue
            mu, sd, sem = mean_sem([p["mu"] for p in g])
            if sd is not None:
                spread[(lat[2], theta)] = sd
            elif (lat[2], theta) in spread:
                # One seed: its error is taken as the seeds' spread on the
                # next narrower lattice (s.e. of one seed = s.d.), said so in
                # the table and the plot.
                sem = spread[(lat[2], theta)]
                assumed = True
            periods = [p["period"] for p in g if p["period"]]
            spreads = [p["spread"] for p in g if p["spread"] is not None]
            stats[theta] = (mu, sem)
            rows.append({
                "lattice": "x".join(map(str, lat)), "coverage": theta, "seeds": len(g),
                "mu": f"{mu:.6g}", "mu_sd": f"{sd:.3g}" if sd else "",
                "mu_sem": (f"{sem:.3g}" + (" (assumed)" if sd is None else "")) if sem else "",
                "F_f_spread": f"{sum(spreads) / len(spreads):.3g}" if spreads else "",
                "period_ms": f"{1e3 * sum(periods) / len(periods):.3g}" if periods else "",
                "cycles": min(p["cycles"] for p in g),
                "wall_hours_per_point": f"{max(p['wall_hours'] for p in g):.2g}",
            })
        if LOW in stats and HIGH in stats:
            (lo, lo_sem), (hi, hi_sem) = stats[LOW], stats[HIGH]
            drop = 1 - hi / lo
            err = None
            if lo_sem is not None and hi_sem is not None:
                err = (hi / lo) * math.hypot(hi_sem / hi, lo_sem / lo)
            drops.append((lat, drop, err, assumed))
            seeds[lat] = (len(groups[lat + (LOW,)]), len(groups[lat + (HIGH,)]))

    table = sweep_dir / "finite_size.csv"
    with table.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
        f.write("\nlattice,drop,drop_error\n")
        for lat, drop, err, assumed in drops:
            f.write(f"{'x'.join(map(str, lat))},{drop:.4g},"
                    f"{'' if err is None else f'{err:.2g}'}{' (assumed)' if assumed else ''}\n")
    for r in rows:
        print(", ".join(f"{k}={v}" for k, v in r.items()))

    fig, ax = plt.subplots(figsize=(6.5, 4))
    thin = [x for x in drops if x[0][2] == 10]
    thick = [x for x in drops if x[0][2] != 10]
    for series, marker, label in ((thin, "o", "Nz = 10"), (thick, "s", "Nz scaled with the width")):
        for kind in (False, True):  # measured errors, then assumed ones (hollow)
            part = [x for x in series if x[3] == kind]
            if not part:
                continue
            x = [1 / lat[0] for lat, _, _, _ in part]
            y = [100 * d for _, d, _, _ in part]
            yerr = [100 * e if e is not None else 0 for _, _, e, _ in part]
            ax.errorbar(x, y, yerr=yerr, marker=marker, ls="none", capsize=3,
                        mfc="white" if kind else None, color="C0" if marker == "o" else "C1",
                        label=label + (", one seed at a load: error assumed from the narrower"
                                       " lattice's seeds" if kind else ""))
            for (lat, d, e, _), xi in zip(part, x):
                ax.annotate(f"{lat[0]}×{lat[1]}×{lat[2]}\n{seeds[lat][0]} + {seeds[lat][1]} seeds",
                            (xi, 100 * d), textcoords="offset points", xytext=(6, 4), fontsize=7)
                print(f"{'x'.join(map(str, lat))}: drop {100 * d:.1f} %"
                      + (f" ± {100 * e:.1f} %" if e is not None else " (one seed: no error)")
                      + (" (error assumed)" if kind else ""))
    # Weighted straight line in 1/L through the Nz = 10 widths that have an
    # error; its intercept is the drop of an infinitely wide block.
    fit = [(1 / lat[0], d, e) for lat, d, e, _ in thin if e]
    any_assumed = any(a for lat, _, e, a in thin if e)
    if len(fit) >= 3:
        x, y, e = (np.array(v) for v in zip(*fit))
        coef, cov = np.polyfit(x, y, 1, w=1 / e, cov="unscaled")
        slope, intercept = coef
        sigma = math.sqrt(cov[1, 1])
        xs = np.linspace(0, max(x) * 1.05, 50)
        chi2 = float(np.sum(((y - (intercept + slope * x)) / e) ** 2))
        widths = 1 / x
        next_width = 2 * round(widths.max())
        ax.plot(xs, 100 * (intercept + slope * xs), "k--", lw=1,
                label=f"weighted fit in 1/L: L → ∞ drop {100 * intercept:.1f} % ± {100 * sigma:.1f} %"
                      f" (χ² {chi2:.2g}, {len(fit) - 2} d.o.f.)" + (", an error assumed" if any_assumed else ""))
        print(f"extrapolated drop at L -> infinity: {100 * intercept:.2f} % +- {100 * sigma:.2f} %"
              f" (chi2 {chi2:.3g} for {len(fit) - 2} degrees of freedom)"
              + (" with an assumed error" if any_assumed else ""))
        at_next = intercept + slope / next_width
        print(f"1/L model: drop at {next_width} wide {100 * at_next:.2f} %")
        # The same points read as a drop that goes to zero, slowly: a L^-p.
        # Fitted in L itself with the same weights, so its χ² compares
        # with the line's.
        (a, p), pcov = curve_fit(lambda L, a, p: a * L ** -p, widths, y, p0=(y[0] * widths[0] ** 0.3, 0.3),
                                 sigma=e, absolute_sigma=True)
        p_sigma = math.sqrt(pcov[1, 1])
        chi2_power = float(np.sum(((y - a * widths ** -p) / e) ** 2))
        power_next = a * next_width ** -p
        xs_power = xs[1:]  # 1/L > 0: the power law is 0 only at L → ∞
        ax.plot(xs_power, 100 * a * xs_power ** p, "k:", lw=1,
                label=f"or vanishing as $a L^{{-p}}$: p = {p:.2f} ± {p_sigma:.2f} (χ² {chi2_power:.2g})")
        print(f"power law to zero: p = {p:.3f} +- {p_sigma:.3f} (chi2 {chi2_power:.3g});"
              f" drop at {next_width} wide {100 * power_next:.2f} %")
        with table.open("a") as f:
            f.write(f"infinity,{intercept:.4g},{sigma:.2g}{' (assumed)' if any_assumed else ''}\n")
            f.write("\nmodel,limit,limit_error,chi2,width,drop_there\n")
            f.write(f"a + b/L,{intercept:.4g},{sigma:.2g},{chi2:.3g},{next_width},{at_next:.4g}\n")
            f.write(f"a L^-p,0,,{chi2_power:.3g},{next_width},{power_next:.4g}\n")
    else:
        print(f"no extrapolation: {len(fit)} width(s) with an error bar at Nz = 10 (3 needed)")
        # Top centre: the axes fit the points, so a corner can hold one.
        ax.text(0.5, 0.96, f"no extrapolation yet: {len(fit)} of the ≥ 3 widths needed",
                transform=ax.transAxes, fontsize=8, ha="center", va="top")
    ax.set_xlim(left=0)
    ax.set_xlabel("1 / L   (L = Nx = Ny)")
    ax.set_ylabel("drop of μ, θ = 0.04 → 0.498 [%]")
    ax.set_title("Finite size: μ's drop with load, v = 1e-3 m/s (mean ± s.e. over seeds)",
                 fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    for ext in ("png", "pdf"):
        fig.savefig(sweep_dir / f"finite_size.{ext}", dpi=120)
    print(f"wrote {table}, {sweep_dir / 'finite_size.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
