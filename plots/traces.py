#!/usr/bin/python3
"""Velocity traces of the traced contacts, one panel per contact (the paper's Fig. 10).

Usage: /usr/bin/python3 plots/traces.py OUTDIR   -> OUTDIR/traces.png and traces.pdf

Prints what each panel shows (the contact, its samples, its largest v_x and
its v*) and the title, so the figure can be checked against the run's tables.
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from _command_line import arguments, directories  # noqa: E402
from run_tables import read_table, where  # noqa: E402


def main() -> int:
    (out,) = directories(arguments(__doc__, 1, 1))
    traces = read_table(out, "traces")
    if traces is None:
        print(f"error: {where(out, 'traces')}: no traces (set [output] traces in the case)",
              file=sys.stderr)
        return 2
    t_ms = traces["t"] * 1e3
    ids = [name[3:] for name in traces if name.startswith("vx_")]
    v_star = {}
    contacts = read_table(out, "contacts")
    if contacts is not None:
        for cid, v in zip(contacts["id"], contacts["v_star"]):
            v_star[str(int(cid))] = float(v)
    summary = {}
    if (out / "summary.json").is_file():
        summary = json.loads((out / "summary.json").read_text())
    drive = summary.get("case", {}).get("drive", {}).get("velocity")

    fig, axes = plt.subplots(len(ids), 1, figsize=(8, 2.2 * len(ids) + 0.6), sharex=True, squeeze=False)
    for ax, cid in zip(axes[:, 0], ids):
        vx = traces[f"vx_{cid}"]
        ax.plot(t_ms, vx, lw=0.8, color="C0")
        label = f"contact {cid}"
        shown = f"contact {cid}: {len(vx)} samples, max vx = {max(vx):.9g} m/s"
        if cid in v_star:
            label += f", v* = {v_star[cid]:.3g} m/s"
            shown += f", v* = {v_star[cid]:.9g} m/s"
            ax.axhline(v_star[cid], color="C3", lw=0.6, ls="--", label="v*")
        print(shown)
        if drive is not None:
            ax.axhline(drive, color="0.5", lw=0.6, ls=":", label="drive v")
        ax.set_ylabel("$v_x$ (m/s)")
        ax.set_title(label, fontsize=9, loc="left")
        ax.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("time (ms)")
    if summary:
        title = f"μ = {summary['mu']:.4f}, θ = {summary['theta']:.4g}"
        fig.suptitle(title, fontsize=10)
        print(f"title: {title}")
    fig.tight_layout()
    fig.savefig(out / "traces.png", dpi=120)
    fig.savefig(out / "traces.pdf")
    print(f"wrote {out / 'traces.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
