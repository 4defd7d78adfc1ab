#!/usr/bin/python3
"""Synchronization of the two contacts of Fig. 10 against their separation
(cases/pair_separation.toml): slip-rate ratio, lag of the nearest slip of
contact 2 against the elastic travel times at the transverse and longitudinal
sound speeds, coincident fraction and cross-correlation peak. Separations along
x and along the diagonal are told apart.

Usage: /usr/bin/python3 plots/pair_separation.py SWEEP_DIR
       -> SWEEP_DIR/pair_separation.png and .pdf
"""
import csv
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from _command_line import arguments, directories  # noqa: E402
from run_tables import read_table, where  # noqa: E402


def wrap(d: int, n: int) -> int:
    d = abs(d) % n
    return min(d, n - d)


def number(text: str) -> float:
    return float(text) if text not in ("", None) else math.nan


def main() -> int:
    (sweep,) = directories(arguments(__doc__, 1, 1))
    table = sweep / "sweep.csv"
    if not table.is_file():
        print(f"error: {table}: not found (run `stickslip sweep` first)", file=sys.stderr)
        return 2
    with table.open() as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "finished"]
    if not rows or "slip_rate_ratio" not in rows[0]:
        print(f"error: {table}: no finished two-contact points", file=sys.stderr)
        return 2
    points = []
    for r in rows:
        out = sweep / r["point"]
        summary = json.loads((out / "summary.json").read_text())
        lattice = summary["case"]["lattice"]
        c = read_table(out, "contacts")
        if c is None:
            print(f"error: {where(out, 'contacts')}: not found", file=sys.stderr)
            return 2
        dx = wrap(int(c["ix"][1]) - int(c["ix"][0]), lattice["nx"])
        dy = wrap(int(c["iy"][1]) - int(c["iy"][0]), lattice["ny"])
        material = summary["case"]["material"]
        nu = material["poisson_ratio"]
        g2_over_g1 = (1 + 2 * nu) if material["grad_div"] == "paper" else 1 / (1 - 2 * nu)
        sync = summary["synchronization"]
        t_transverse = sync.get("coincidence_window", sync.get("window"))  # d / c_t (older: "window")
        direction = "x" if dy == 0 else ("diagonal" if dx == dy else "other")
        points.append({
            "sep": math.hypot(dx, dy), "dir": direction,
            "ratio": number(r["slip_rate_ratio"]), "lag": number(r["lag_mean"]),
            "lag_min": number(r["lag_min"]), "lag_max": number(r["lag_max"]),
            "coincident": number(r["coincident_fraction"]), "xcorr": number(r["xcorr_peak"]),
            "t_t": t_transverse, "t_l": t_transverse / math.sqrt(1 + g2_over_g1),
        })
    points.sort(key=lambda p: (p["dir"], p["sep"]))
    for p in points:
        print(f"{p['dir']:8s} separation {p['sep']:.3g} a: ratio {p['ratio']:.3g}, lag {p['lag'] * 1e6:.3g} us "
              f"(travel {p['t_l'] * 1e6:.3g} us at c_l, {p['t_t'] * 1e6:.3g} us at c_t), "
              f"coincident {p['coincident']:.3g}, xcorr {p['xcorr']:.3g}")

    fig, axes = plt.subplots(2, 2, figsize=(9, 6), sharex=True)
    markers = {"x": "o", "diagonal": "s", "other": "^"}
    for d in sorted({p["dir"] for p in points}):
        ps = [p for p in points if p["dir"] == d]
        sep = [p["sep"] for p in ps]
        kw = dict(marker=markers[d], ms=5, lw=1, label=f"along {d}")
        axes[0, 0].plot(sep, [p["ratio"] for p in ps], **kw)
        lo = [p["lag"] - p["lag_min"] for p in ps]
        hi = [p["lag_max"] - p["lag"] for p in ps]
        axes[0, 1].errorbar(sep, [p["lag"] * 1e6 for p in ps], yerr=[[x * 1e6 for x in lo], [x * 1e6 for x in hi]],
                            capsize=3, **kw)
        axes[1, 0].plot(sep, [p["coincident"] for p in ps], **kw)
        axes[1, 1].plot(sep, [p["xcorr"] for p in ps], **kw)
    ps = sorted(points, key=lambda p: p["sep"])
    axes[0, 1].plot([p["sep"] for p in ps], [p["t_t"] * 1e6 for p in ps], "k--", lw=0.8, label="travel time at $c_t$")
    axes[0, 1].plot([p["sep"] for p in ps], [p["t_l"] * 1e6 for p in ps], "k:", lw=0.8, label="travel time at $c_l$")
    axes[0, 0].set_ylabel("slips of contact 2 per slip of contact 1")
    axes[0, 1].set_ylabel("lag to nearest slip of contact 2 (µs)")
    axes[1, 0].set_ylabel("fraction coincident within $d/c_t$")
    axes[1, 1].set_ylabel("cross-correlation peak of $v_x$")
    for ax in axes.flat:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    for ax in axes[1]:
        ax.set_xlabel("separation (lattice constants)")
    fig.suptitle("Two contacts (v* = 4.75e-4, 2.09e-3 m/s) against their separation", fontsize=10)
    fig.tight_layout()
    for ext in ("png", "pdf"):
        fig.savefig(sweep / f"pair_separation.{ext}", dpi=130)
    print(f"wrote {sweep / 'pair_separation.png'} and .pdf")
    return 0


if __name__ == "__main__":
    sys.exit(main())
