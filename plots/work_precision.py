#!/usr/bin/python3
"""Error against wall time from bench/work_precision.py's output: one row of
panels per case (output directory), one panel per error measure (μ, velocity
traces, event times, final state), one curve per method.

Also writes, for each case, DIR/best_times.md: the least wall time at which
each method reaches each error level of μ, and the ratios of the default
(imex at rtol 1e-6) to the fixed-step runs at equal μ error.

Usage: /usr/bin/python3 plots/work_precision.py DIR [DIR ...] [--out FILE.png]
  -> FILE.png and .pdf (default: DIR/work_precision.png for one DIR)
"""
import argparse
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from _command_line import directories  # noqa: E402

MEASURES = [("mu_error", "μ relative error"), ("trace_error", "trace relative L2 error"),
            ("event_error", "largest event time error (s)"), ("state_error", "final-state relative L2 error")]
LEVELS = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8]
DEFAULT = ("imex", "rtol=1e-06")
COLORS = {"imex": "C0", "imex-fixed": "C1", "rk4": "C2", "erk": "C3", "dirk": "C4", "bdf": "C5",
          "dirk-fixed": "C6"}


def number(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return None


def read(directory):
    table = directory / "work_precision.csv"
    if not table.is_file():
        raise SystemExit(f"error: {table}: not found (run bench/work_precision.py first)")
    with table.open() as f:
        return list(csv.DictReader(f))


def best_times(rows):
    """Markdown: least wall time per method reaching each μ error level, and
    the default's ratios to the fixed-step runs at its own μ error."""
    done = [r for r in rows if r["status"] == "finished" and number(r["mu_error"]) is not None]
    methods = sorted({r["method"] for r in rows})
    lines = ["| method | " + " | ".join(f"μ err ≤ {x:g}" for x in LEVELS) + " |",
             "|---|" + "---|" * len(LEVELS)]
    for m in methods:
        cells = []
        for level in LEVELS:
            ok = [float(r["wall_seconds"]) for r in done if r["method"] == m and abs(float(r["mu_error"])) <= level]
            cells.append(f"{min(ok):.3g} s" if ok else "–")
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    unfinished = [r for r in rows if r["status"] != "finished"]
    for r in unfinished:
        extra = f", extrapolated to the whole horizon: {float(r['extrapolated_wall_seconds']):.3g} s" \
            if number(r.get("extrapolated_wall_seconds")) else ""
        lines.append(f"\n{r['method']} {r['setting']}: {r['status']} after {float(r['wall_seconds']):.3g} s"
                     f" at t = {r.get('t_reached') or '?'} s{extra}.")
    default = [r for r in done if (r["method"], r["setting"]) == DEFAULT]
    if default:
        d = default[0]
        e, w = abs(float(d["mu_error"])), float(d["wall_seconds"])
        lines.append(f"\nDefault ({DEFAULT[0]} {DEFAULT[1]}): {w:.3g} s, μ error {e:.2g}.")
        for m in sorted({r["method"] for r in rows if r["method"] in ("imex-fixed", "dirk-fixed", "rk4")}):
            ok = [r for r in done if r["method"] == m and abs(float(r["mu_error"])) <= e]
            if ok:
                best = min(ok, key=lambda r: float(r["wall_seconds"]))
                lines.append(f"- {m}: cheapest run at least as accurate: {best['setting']}, "
                             f"{float(best['wall_seconds']):.3g} s → ratio {float(best['wall_seconds']) / w:.3g}")
            else:
                slow = [r for r in rows if r["method"] == m and number(r.get("extrapolated_wall_seconds"))]
                if slow:
                    x = min(float(r["extrapolated_wall_seconds"]) for r in slow)
                    lines.append(f"- {m}: no run finished; its pace extrapolates to ≥ {x:.3g} s → ratio ≥ {x / w:.3g}")
                else:
                    lines.append(f"- {m}: no run reached μ error ≤ {e:.2g}")
    return "\n".join(lines) + "\n"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("dirs", nargs="+", type=Path)
    p.add_argument("--out", type=Path)
    a = p.parse_args()
    directories(a.dirs)
    if a.out is None and len(a.dirs) > 1:
        print("error: --out FILE.png is needed with more than one directory", file=sys.stderr)
        return 2
    out = a.out or a.dirs[0] / "work_precision.png"
    cases = [(d, read(d)) for d in a.dirs]
    fig, axes = plt.subplots(len(cases), len(MEASURES), figsize=(16, 3.8 * len(cases)), squeeze=False)
    for row, (d, rows) in zip(axes, cases):
        (d / "best_times.md").write_text(best_times(rows))
        done = [r for r in rows if r["status"] == "finished"]
        methods = sorted({r["method"] for r in rows})
        for ax, (key, label) in zip(row, MEASURES):
            for method in methods:
                # Along the ladder: loosest tolerance (largest step) first.
                pts = sorted(((float(r["wall_seconds"]), abs(float(r[key])), r["setting"])
                              for r in done if r["method"] == method and number(r.get(key))),
                             key=lambda q: -float(q[2].split("=")[1]))
                pts = [q for q in pts if q[1] > 0]
                if not pts:
                    continue
                ax.loglog([q[0] for q in pts], [q[1] for q in pts], marker="o", ms=4, lw=1,
                          color=COLORS.get(method, "k"), label=method)
                for w, e, s in pts:
                    ax.annotate(s.split("=")[1], (w, e), fontsize=6, xytext=(3, 3), textcoords="offset points")
            ax.set_xlabel("wall time (s)")
            ax.set_ylabel(label)
            ax.set_title(d.name, fontsize=9)
            ax.grid(alpha=0.3, which="both")
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=7)
            else:
                ax.text(0.5, 0.5, "not measured for this case", ha="center", va="center",
                        transform=ax.transAxes, fontsize=8, color="gray")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    fig.savefig(out.with_suffix(".pdf"))
    print(f"wrote {out} and .pdf; best_times.md in each directory")
    return 0


if __name__ == "__main__":
    sys.exit(main())
