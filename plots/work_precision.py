#!/usr/bin/python3
"""Error against wall time, one curve per method, one panel per error measure
(μ, velocity traces, event times), from bench/work_precision.py's output.

Usage: /usr/bin/python3 plots/work_precision.py DIR  -> DIR/work_precision.png and .pdf
"""
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

MEASURES = [("mu_error", "μ relative error"), ("trace_error", "trace relative L2 error"),
            ("event_error", "largest event time error (s)")]


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    out = Path(sys.argv[1])
    table = out / "work_precision.csv"
    if not table.is_file():
        print(f"error: {table}: not found (run bench/work_precision.py first)", file=sys.stderr)
        return 2
    with table.open() as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "finished"]
    fig, axes = plt.subplots(1, len(MEASURES), figsize=(13, 4))
    for ax, (key, label) in zip(axes, MEASURES):
        for i, method in enumerate(sorted({r["method"] for r in rows})):
            pts = sorted((float(r["wall_seconds"]), abs(float(r[key])), r["setting"])
                         for r in rows if r["method"] == method and r[key] not in ("", "0", "0.0"))
            if not pts:
                continue
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], marker="o", ms=4, lw=1, color=f"C{i}", label=method)
            for w, e, s in pts:
                ax.annotate(s, (w, e), fontsize=6, xytext=(3, 3), textcoords="offset points")
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    fig.suptitle(f"work against precision: {out.name}", fontsize=10)
    fig.tight_layout()
    for ext in ("png", "pdf"):
        fig.savefig(out / f"work_precision.{ext}", dpi=120)
    print(f"wrote {out / 'work_precision.png'} and .pdf")
    return 0


if __name__ == "__main__":
    sys.exit(main())
