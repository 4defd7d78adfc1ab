#!/usr/bin/python3
"""Error against wall time from bench/work_precision.py's output: one row of
panels per case (output directory), one panel per error measure (μ, velocity
traces, event times, final state; a measure no case has is left out), one
curve per method. A "floor" row (the driver's --floor: the reference against
itself with the drive speed changed by 1e-12) is drawn as a labelled line
with a grey band below it: errors in the band mean nothing. Runs stopped at
the driver's timeout are hollow markers along a panel's top, at the wall time
their pace extrapolates to.

Also writes, for each case, DIR/best_times.md: the least wall time at which
each method reaches each error level of μ, the ratios of the default to the
fixed-step runs at equal μ error, and every method's cheapest run at least
as accurate as the default in μ and in slip times. The default is the method
`auto` chose at the default rtol (DIR/meta.json, written by the driver), or
imex at rtol 1e-6 where there is no meta.json.

Usage: /usr/bin/python3 plots/work_precision.py DIR [DIR ...] [--out FILE.png]
  -> FILE.png and .pdf (default: DIR/work_precision.png for one DIR)
"""
import argparse
import csv
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from _command_line import directories  # noqa: E402

MEASURES = [("mu_error", "μ relative error"), ("trace_error", "trace relative L2 error"),
            ("event_error", "largest slip/stick time error (s)"),
            ("state_error", "final-state relative L2 error")]
LEVELS = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8]
DEFAULT = ("imex", "rtol=1e-06")
COLORS = {"imex": "C0", "imex-fixed": "C1", "rk4": "C2", "erk": "C3", "dirk": "C4", "bdf": "C5",
          "dirk-fixed": "C6", "multirate": "C9"}
MARKERS = {"imex": "o", "imex-fixed": "s", "rk4": "x", "erk": "v", "dirk": "D", "bdf": "^",
           "dirk-fixed": "P", "multirate": "*"}
FIXED = ("imex-fixed", "dirk-fixed", "rk4")


def meta(directory):
    f = directory / "meta.json"
    return json.loads(f.read_text()) if f.is_file() else {}


def default_run(info):
    """(method, setting) of the default: auto's choice at the default rtol."""
    if "auto_method" in info:
        return info["auto_method"], f"rtol={info['default_rtol']:g}"
    return DEFAULT


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


def best_times(rows, info=None):
    """Markdown: least wall time per method reaching each μ error level, and
    the default's ratios to the fixed-step runs at its own μ error."""
    info = info or {}
    default_key = default_run(info)
    floor = [r for r in rows if r["method"] == "floor"]
    rows = [r for r in rows if r["method"] != "floor"]
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
    if floor:
        f = floor[0]
        lines.append(f"\nChaos floor ({f['message'] or f['setting']}): μ error {abs(float(f['mu_error'])):.2g}"
                     + (f", slip-time error {float(f['event_error']):.2g} s" if number(f["event_error"]) else "")
                     + (f", trace error {float(f['trace_error']):.2g}" if number(f["trace_error"]) else "")
                     + ". Errors below it mean nothing.")
    default = [r for r in done if (r["method"], r["setting"]) == default_key]
    if default:
        d = default[0]
        e, w = abs(float(d["mu_error"])), float(d["wall_seconds"])
        lines.append(f"\nDefault ({default_key[0]} {default_key[1]}): {w:.3g} s, μ error {e:.2g}.")
        for m in sorted({r["method"] for r in rows if r["method"] in FIXED}):
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
        lines += at_default_accuracy(d, done, rows, floor[0] if floor else None)
    return "\n".join(lines) + "\n"


def at_default_accuracy(d, done, rows, floor):
    """Each method's cheapest run at least as accurate as the default d in μ
    and (where measured) in slip times, and its wall time over the default's.
    A threshold below the chaos floor is raised to the floor: runs cannot be
    told apart below it."""
    w = float(d["wall_seconds"])
    need = {"mu_error": abs(float(d["mu_error"]))}
    if number(d.get("event_error")) is not None:
        need["event_error"] = float(d["event_error"])
    raised = []
    if floor:
        for k in need:
            if number(floor.get(k)) is not None and abs(float(floor[k])) > need[k]:
                need[k] = abs(float(floor[k]))
                raised.append(k)
    say = " and ".join(f"{'μ' if k == 'mu_error' else 'slip-time'} error ≤ {v:.2g}" for k, v in need.items())
    out = [f"\nAt the default's accuracy ({say}"
           + (f"; raised to the chaos floor in {', '.join(raised)}" if raised else "") + "):", "",
           "| method | cheapest run as accurate | wall | × default |", "|---|---|---|---|"]
    for m in sorted({r["method"] for r in rows}):
        ok = [r for r in done if r["method"] == m
              and all(number(r.get(k)) is not None and abs(float(r[k])) <= v for k, v in need.items())]
        if ok:
            b = min(ok, key=lambda r: float(r["wall_seconds"]))
            out.append(f"| {m} | {b['setting']} | {float(b['wall_seconds']):.3g} s | {float(b['wall_seconds']) / w:.3g} |")
        else:
            out.append(f"| {m} | none | – | – |")
    return out


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
    measures = [(k, lab) for k, lab in MEASURES if any(number(r.get(k)) for _, rows in cases for r in rows)] \
        or MEASURES[:1]
    fig, axes = plt.subplots(len(cases), len(measures), figsize=(5.2 * len(measures), 3.9 * len(cases)),
                             squeeze=False)
    for row, (d, rows) in zip(axes, cases):
        info = meta(d)
        (d / "best_times.md").write_text(best_times(rows, info))
        floor = next((r for r in rows if r["method"] == "floor"), None)
        rows = [r for r in rows if r["method"] != "floor"]
        done = [r for r in rows if r["status"] == "finished"]
        methods = sorted({r["method"] for r in rows})
        title = d.name
        if info:
            title += f" (auto: {info['auto_method']}; reference {info['ref_method']} rtol {info['ref_rtol']:g})"
        for ax, (key, label) in zip(row, measures):
            for method in methods:
                # Along the ladder: loosest tolerance (largest step) first.
                pts = sorted(((float(r["wall_seconds"]), abs(float(r[key])), r["setting"])
                              for r in done if r["method"] == method and number(r.get(key))),
                             key=lambda q: -float(q[2].split("=")[1]))
                pts = [q for q in pts if q[1] > 0]
                if not pts:
                    continue
                ax.loglog([q[0] for q in pts], [q[1] for q in pts], marker=MARKERS.get(method, "o"), ms=4, lw=1,
                          color=COLORS.get(method, "k"), label=method)
                for w, e, s in pts:
                    ax.annotate(s.split("=")[1], (w, e), fontsize=6, xytext=(3, 3), textcoords="offset points")
            # Runs stopped at the timeout: hollow markers along the top, at
            # the wall time their pace extrapolates to.
            if ax.get_legend_handles_labels()[0]:
                top = matplotlib.transforms.blended_transform_factory(ax.transData, ax.transAxes)
                drawn = set(ax.get_legend_handles_labels()[1])
                stopped = sorted({r["method"] for r in rows if r["status"] == "timeout"
                                  and number(r.get("extrapolated_wall_seconds"))})
                for m in stopped:
                    ax.plot([], [], ls="none", marker=MARKERS.get(m, "o"), mfc="none", color=COLORS.get(m, "k"),
                            label=f"{m} stopped (top: time its pace extrapolates to)" if m not in drawn
                            else None)
                for r in rows:
                    x = number(r.get("extrapolated_wall_seconds"))
                    if r["status"] == "timeout" and x:
                        ax.plot([x], [0.96], transform=top, marker=MARKERS.get(r["method"], "o"), ms=6,
                                mfc="none", color=COLORS.get(r["method"], "k"), clip_on=False)
                        ax.annotate(r["setting"].split("=")[1], (x, 0.96), xycoords=top, fontsize=6,
                                    xytext=(0, -6), textcoords="offset points", rotation=90, ha="center",
                                    va="top", color=COLORS.get(r["method"], "k"))
            if floor is not None and number(floor.get(key)) and abs(float(floor[key])) > 0 \
                    and ax.get_legend_handles_labels()[0]:
                fl = abs(float(floor[key]))
                lo, hi = ax.get_ylim()
                lo = min(lo, fl / 3)
                ax.axhspan(lo, fl, color="0.5", alpha=0.18, lw=0)
                ax.axhline(fl, color="0.3", ls="--", lw=1,
                           label=f"chaos floor (drive speed × (1 + {floor['setting'].split('=')[1]}))")
                ax.set_ylim(lo, max(hi * 2, fl * 3))
                ax.annotate("chaos floor", (0.99, fl), xycoords=("axes fraction", "data"), ha="right",
                            va="bottom", fontsize=7, color="0.3")
            ax.set_xlabel("wall time (s)")
            ax.set_ylabel(label)
            ax.set_title(title, fontsize=8)
            ax.grid(alpha=0.3, which="both")
            if ax.get_legend_handles_labels()[0]:
                if ax is row[0] or not any(a.get_legend() for a in row):
                    ax.legend(fontsize=7)
            else:
                ax.text(0.5, 0.5, "not measured for this case", ha="center", va="center",
                        transform=ax.transAxes, fontsize=8, color="gray")
                ax.set_xticks([])
                ax.set_yticks([])
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    fig.savefig(out.with_suffix(".pdf"))
    print(f"wrote {out} and .pdf; best_times.md in each directory")
    return 0


if __name__ == "__main__":
    sys.exit(main())
