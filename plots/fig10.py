#!/usr/bin/python3
"""The paper's Fig. 10: the x-velocities of the two contacts, one lattice
constant apart (a) and seven apart (b), each contact in its own panel.

Usage: /usr/bin/python3 plots/fig10.py OUT_A OUT_B [PNG]
       (outputs of cases/fig10a.toml and cases/fig10b.toml, traces on)
       -> PNG (default OUT_B/../fig10.png) and the same name .pdf
"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from _command_line import arguments, directories  # noqa: E402
from run_tables import read_table, where  # noqa: E402


def load(out: Path):
    traces = read_table(out, "traces")
    if traces is None:
        raise SystemExit(f"error: {where(out, 'traces')}: no traces (set [output] traces = \"all\")")
    ids = [h[3:] for h in traces if h.startswith("vx_")]
    if len(ids) != 2:
        raise SystemExit(f"error: {where(out, 'traces')}: expected two traced contacts, "
                         f"found {len(ids)}")
    contacts = read_table(out, "contacts")
    if contacts is None:
        raise SystemExit(f"error: {where(out, 'contacts')}: not found")
    v_star = {str(int(i)): (float(v), int(ix), int(iy))
              for i, v, ix, iy in zip(contacts["id"], contacts["v_star"], contacts["ix"], contacts["iy"])}
    summary_file = out / "summary.json"
    summary = json.loads(summary_file.read_text()) if summary_file.is_file() else {}
    t = traces["t"] * 1e3
    return summary, t, [(i, traces[f"vx_{i}"], v_star[i]) for i in ids]


def main() -> int:
    args = arguments(__doc__, 2, 3)
    outs = directories(args[:2])
    png = Path(args[2]) if len(args) == 3 else outs[1].parent / "fig10.png"
    fig, axes = plt.subplots(2, 2, figsize=(10, 5), sharex="col")
    for col, (out, name) in enumerate(zip(outs, "ab")):
        summary, t, contacts = load(out)
        (_, _, (_, x0, y0)), (_, _, (_, x1, y1)) = contacts
        sync = summary.get("synchronization", {})
        for row, (cid, vx, (vs, _, _)) in enumerate(contacts):
            ax = axes[row, col]
            ax.plot(t, vx, lw=0.7, color=f"C{row}")
            ax.axhline(vs, color="C3", lw=0.6, ls="--")
            ax.set_ylabel(f"$v_x$ contact {int(cid) + 1} (m/s)", fontsize=8)
            ax.set_title(f"({name}) contact {int(cid) + 1}: v* = {vs:.3g} m/s", fontsize=8, loc="left")
            ax.grid(alpha=0.3)
        if sync:
            print(f"({name}) {out}: separation ({x1 - x0}, {y1 - y0}) a, slip-rate ratio "
                  f"{sync.get('slip_rate_ratio')}, lag mean {sync.get('lag_mean')} s, "
                  f"coincident {sync.get('coincident_fraction')}")
        axes[1, col].set_xlabel("time (ms)")
    fig.suptitle("Fig. 10: two contacts, (a) 1 a apart, (b) 7 a apart; v = 1e-3 m/s", fontsize=10)
    fig.tight_layout()
    fig.savefig(png, dpi=130)
    fig.savefig(png.with_suffix(".pdf"))
    print(f"wrote {png} and {png.with_suffix('.pdf')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
