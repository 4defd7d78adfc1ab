#!/usr/bin/python3
"""How many of the contacts take part in each block-scale slip, and how often
the block slips: the census of a run with events (`[output] events = "all"`).

Usage: /usr/bin/python3 plots/block_slips.py RUN_DIR [RUN_DIR ...]
  -> RUN_DIR/block_slips.csv (one row per block slip: F_f's peak and trough,
     the drop, the span of its slips, how many slips and contacts, and the
     contacts' fraction of all) and RUN_DIR/block_slips.png (F_f/F_N over the
     window, each block slip shaded); one line per run on stdout: the block
     slips, their period, the mean, least and largest fraction of the contacts
     in one, and how many of the window's slips fell outside every block slip.

A block slip is a fall of F_f larger than the ringing, as the run found it
(summary.json's block_slips, whose cycles μ over whole cycles counts; a run
older than that list: where F_f falls through its window mean). Its drop runs
from F_f's peak since the previous fall (or the window's start) to its trough
before the next (or the window's end). Its slips are
those chained in time through the drop: slips.csv's intervals (onset to
arrest) that overlap the drop or, link by link, a slip that does, up to the
first moment no contact slips. Its contacts are theirs, counted once. Only
block slips wholly inside the window count. The period is the mean time
between the falls.
"""
import csv
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from _command_line import arguments, directories  # noqa: E402
import numpy as np  # noqa: E402
from run_tables import read_table, where  # noqa: E402

USAGE = __doc__.split("\n\n")[1]


def falls_through(t, f, level):
    """Times where f falls through level (linear between samples)."""
    i = np.nonzero((f[:-1] >= level) & (f[1:] < level))[0]
    return t[i] + (f[i] - level) / (f[i] - f[i + 1]) * (t[i + 1] - t[i])


def slip_clusters(slip_start, slip_end):
    """The slips chained in time: index arrays of slips whose intervals overlap
    one another's, from one moment no contact slips to the next."""
    clusters, current, reach = [], [], -np.inf
    for i in np.argsort(slip_start, kind="stable"):
        if current and slip_start[i] > reach:
            clusters.append(np.array(current))
            current, reach = [], -np.inf
        current.append(i)
        reach = max(reach, slip_end[i])
    if current:
        clusters.append(np.array(current))
    return clusters


def block_slips(t, f, slip_start, slip_end, slip_contact, contacts, t_from, found=None):
    """The block slips of F_f(t) in [t_from, t[-1]], each a dict (F_f's peak
    and trough, the span of the slips chained through the drop, how many slips
    and contacts, and which slips: "members", indices into slip_start); the falls' times; the window's mean of F_f; and which slips
    belong to a block slip."""
    keep = t >= t_from
    t, f = t[keep], f[keep]
    mean = np.trapz(f, t) / (t[-1] - t[0])
    if found is None:
        falls = falls_through(t, f, mean)
    else:  # the run's: midway down each fall, the peak before it and the trough after
        falls = np.array([0.5 * (b["onset"] + b["end"]) for b in found
                          if t[0] <= 0.5 * (b["onset"] + b["end"]) <= t[-1]])
    bounds = np.concatenate(([t[0]], falls, [t[-1]]))
    clusters = slip_clusters(slip_start, slip_end)
    spans = [(slip_start[c].min(), slip_end[c].max()) for c in clusters]
    rows, in_block = [], np.zeros(len(slip_start), dtype=bool)
    for k, fall in enumerate(falls):
        before = (t > bounds[k]) & (t <= fall)
        after = (t >= fall) & (t < bounds[k + 2])
        if not before.any() or not after.any():
            continue
        i_peak = np.flatnonzero(before)[np.argmax(f[before])]
        i_trough = np.flatnonzero(after)[np.argmin(f[after])]
        t0, t1 = t[i_peak], t[i_trough]
        chained = [c for c, (a, b) in zip(clusters, spans) if a <= t1 and b >= t0]
        if not chained:
            continue
        members = np.concatenate(chained)
        first, last = slip_start[members].min(), slip_end[members].max()
        if i_peak == 0 or i_trough == len(t) - 1 or first < t[0] or last > t[-1]:
            continue  # cut off by the window's start or end
        in_block[members] = True
        taking_part = np.unique(slip_contact[members])
        rows.append({
            "t_peak": t0, "F_peak": f[i_peak], "t_trough": t1, "F_trough": f[i_trough],
            "first": first, "last": last, "slips": len(members),
            "contacts": len(taking_part), "fraction": len(taking_part) / contacts,
            "members": members,  # indices of its slips in the slip arrays
        })
    return rows, falls, mean, in_block


def fail(message: str):
    print(f"error: {message}", file=sys.stderr)
    raise SystemExit(2)


def census(run: Path):
    """The run's summary, F_f table, block slips, falls, F_f's window mean, and
    (slips outside every block slip, slips) within the window."""
    if not (run / "summary.json").is_file():
        fail(f"{run / 'summary.json'}: not found (not a finished run's directory)")
    summary = json.loads((run / "summary.json").read_text())
    friction = read_table(run, "friction")
    slips = read_table(run, "slips")
    if friction is None:
        fail(f"{where(run, 'friction')}: not found (the run wrote no F_f)")
    if slips is None or summary["case"]["output"]["events"] != "all":
        fail(f"{run}: the census needs every contact's slips; run the case with "
             "[output] events = \"all\"")
    t_from = summary["average_from"]
    rows, falls, mean, in_block = block_slips(friction["t"], friction["F_f"], slips["t_start"],
                                              slips["t_end"], slips["contact"].astype(int),
                                              summary["contacts"], t_from, summary.get("block_slips"))
    inside = (slips["t_start"] >= t_from) & (slips["t_end"] <= friction["t"][-1])
    outside = int((inside & ~in_block).sum())
    return summary, friction, rows, falls, mean, (outside, int(inside.sum()))


def write_csv(path: Path, rows):
    with path.open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["t_peak", "t_trough", "F_f_peak", "F_f_trough", "drop", "first_onset",
                    "last_arrest", "slips", "contacts", "fraction"])
        for r in rows:
            w.writerow([f"{r['t_peak']:.6g}", f"{r['t_trough']:.6g}", f"{r['F_peak']:.6g}",
                        f"{r['F_trough']:.6g}", f"{1 - r['F_trough'] / r['F_peak']:.4f}",
                        f"{r['first']:.8g}", f"{r['last']:.8g}", r["slips"], r["contacts"],
                        f"{r['fraction']:.4f}"])


def plot(path: Path, summary, friction, rows, mean):
    keep = friction["t"] >= summary["average_from"]
    t = friction["t"][keep] * 1e3
    fn = summary["F_N"]
    fig, ax = plt.subplots(figsize=(8, 3.6))
    ax.plot(t, friction["F_f"][keep] / fn, lw=0.8, color="C0", label="F_f / F_N")
    ax.axhline(mean / fn, color="0.5", lw=0.6, ls="--", label="window mean")
    for r in rows:
        ax.axvspan(r["first"] * 1e3, r["last"] * 1e3, color="C3", alpha=0.3, lw=0)
        ax.annotate(f"{100 * r['fraction']:.0f} %", (r["last"] * 1e3, r["F_trough"] / fn),
                    fontsize=7, xytext=(3, -9), textcoords="offset points")
    lattice = summary["case"]["lattice"]
    ax.set_title(f"{lattice['nx']}x{lattice['ny']}x{lattice['nz']}, θ = {summary['theta']:.3g}, "
                 f"{summary['contacts']} contacts: block slips shaded, with the share of the "
                 "contacts slipping in each", fontsize=9)
    ax.set_xlabel("t (ms)")
    ax.set_ylabel("μ")
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    fig.savefig(path.with_suffix(".pdf"))
    plt.close(fig)


def main():
    for run in directories(arguments(USAGE, 1)):
        summary, friction, rows, falls, mean, (outside, inside) = census(run)
        write_csv(run / "block_slips.csv", rows)
        plot(run / "block_slips.png", summary, friction, rows, mean)
        lattice = summary["case"]["lattice"]
        period = np.diff(falls).mean() if len(falls) >= 2 else float("nan")
        if rows:
            fr = np.array([r["fraction"] for r in rows])
            share = (f"contacts per block slip {100 * fr.mean():.1f} % "
                     f"({100 * fr.min():.1f}–{100 * fr.max():.1f} %), lasting "
                     f"{1e6 * np.mean([r['last'] - r['first'] for r in rows]):.0f} µs")
        else:
            share = "no block slip wholly in the window"
        print(f"{run}: {lattice['nx']}x{lattice['ny']}x{lattice['nz']}, theta "
              f"{summary['theta']:.3g}, {summary['contacts']} contacts: {len(rows)} block slips, "
              f"period {1e3 * period:.3g} ms, {share}; {outside} of the window's {inside} slips "
              "outside them")


if __name__ == "__main__":
    sys.exit(main())
