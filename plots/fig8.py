#!/usr/bin/python3
"""The paper's Fig. 8: friction force per unit coverage, F_f/θ, against time
(at v = 1e-3 m/s in the paper), for a low and a high coverage (small
fluctuations against block-scale stick-slip).

Usage: /usr/bin/python3 plots/fig8.py OUT_LOW OUT_HIGH [PNG]
       (outputs of cases/fig8_low.toml and cases/fig8_high.toml)
       -> PNG (default OUT_HIGH/../fig8.png) and the same name .pdf;
          the title names the lattice and v of the runs (summary.json)
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
    summary_file = out / "summary.json"
    friction = read_table(out, "friction")
    if friction is None:
        raise SystemExit(f"error: {where(out, 'friction')}: not found")
    summary = json.loads(summary_file.read_text()) if summary_file.is_file() else {}
    theta = summary.get("theta")
    if theta is None:
        raise SystemExit(f"error: {summary_file}: no theta (the run has not finished)")
    rows = list(zip(friction["t"].tolist(), friction["F_f"].tolist()))
    return summary, theta, rows


def main() -> int:
    args = arguments(__doc__, 2, 3)
    low, high = directories(args[:2])
    png = Path(args[2]) if len(args) == 3 else high.parent / "fig8.png"
    fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    lattices, velocities = [], []
    for ax, out in zip(axes, (low, high)):
        summary, theta, rows = load(out)
        case = summary.get("case", {})
        size = case.get("lattice", {})
        lattice = "×".join(str(size.get(n, "?")) for n in ("nx", "ny", "nz"))
        velocity = case.get("drive", {}).get("velocity")
        for seen, value in ((lattices, lattice), (velocities, velocity)):
            if value is not None and value not in seen:
                seen.append(value)
        t_avg = summary.get("average_from", 0.0)
        t = [r[0] * 1e3 for r in rows]
        f = [r[1] / theta for r in rows]
        ax.plot(t, f, lw=0.7)
        window = [v for (tt, v) in zip((r[0] for r in rows), f) if tt >= t_avg]
        if window:
            mean = sum(window) / len(window)
            sd = (sum((v - mean) ** 2 for v in window) / len(window)) ** 0.5
            rel = (max(window) - min(window)) / mean if mean else float("nan")
            print(f"{out}: theta={theta:.4g} mu={summary['mu']:.6g} F_f/theta mean={mean:.6g} "
                  f"max={max(window):.6g} min={min(window):.6g} std/mean={sd / mean:.4g} "
                  f"peak-to-peak/mean={rel:.4g} (t >= {t_avg:g} s)")
        ax.axvline(t_avg * 1e3, color="0.6", lw=0.6, ls=":")
        ax.set_ylabel("$F_f/\\theta$ (N)")
        regime = summary.get("regime") or {}
        flag = "" if regime.get("mu_trusted", True) else f" — not friction: {regime['kind']} window, run longer"
        ax.set_title(f"θ = {theta:.3g}, μ = {summary['mu']:.4g}{flag}", fontsize=9, loc="left",
                     color="red" if flag else "black")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (ms)")
    title = "Fig. 8: friction force per coverage"
    if lattices:
        title += ", " + " and ".join(lattices)
    if velocities:
        title += ", v = " + " and ".join(f"{v:g}" for v in velocities) + " m/s"
    print(f"title: {title}")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(png, dpi=130)
    fig.savefig(png.with_suffix(".pdf"))
    print(f"wrote {png} and {png.with_suffix('.pdf')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
