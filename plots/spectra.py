#!/usr/bin/python3
"""Power spectra of a run's signals.csv ([output] signals = true): the block's
centre-of-mass velocity and the interface's acoustic signal (the rate of change
of the total contact force), the observables the paper proposes (Sec. 6) for
seeing the contacts' stick-slip in experiments.

Usage: /usr/bin/python3 plots/spectra.py DIR [DIR...] [--segment SECONDS] [--out PNG]

For each DIR: one-sided power spectral densities by Welch's method (Hann
window, half-overlapping segments, mean removed) over the run's averaging
window [average_from, t_end] (summary.json), written to DIR/spectrum.csv:

    f                    frequency [Hz]
    psd_block_velocity   PSD of the block velocity [(m/s)^2/Hz]
    psd_acoustic         PSD of the acoustic signal [(N/s)^2/Hz]

Each PSD integrates over f to the signal's variance in the window. Segments
are a quarter of the window unless --segment says otherwise (resolution
1/segment; longer segments resolve lines better and average less). The
sampling rate is the run's output rate; nothing above half of it is seen.
One log-log picture with a curve per run (two panels) goes to --out, by
default the first DIR/spectrum.png (and .pdf).
"""
import argparse
import csv
import json
import sys
from pathlib import Path

import numpy as np
from scipy.signal import welch

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from _command_line import directories  # noqa: E402
from run_tables import read_table, where  # noqa: E402


def fail(message: str):
    print(f"error: {message}", file=sys.stderr)
    raise SystemExit(2)


def load(run: Path):
    signals, summary_file = read_table(run, "signals"), run / "summary.json"
    if signals is None:
        fail(f"{where(run, 'signals')}: not found (run the case with [output] signals = true)")
    if not summary_file.is_file():
        fail(f"{summary_file}: not found (the run has not finished)")
    summary = json.loads(summary_file.read_text())
    data = np.column_stack([signals["t"], signals["block_velocity"], signals["acoustic"]])
    t_from, t_end = summary["average_from"], summary["t_end"]
    window = (data[:, 0] >= t_from - 1e-12) & (data[:, 0] <= t_end + 1e-12) & np.isfinite(data[:, 2])
    data = data[window]
    if len(data) < 16:
        fail(f"{where(run, 'signals')}: only {len(data)} rows in [{t_from}, {t_end}] s")
    return summary, data


def spectra(data, segment):
    t = data[:, 0]
    dt = np.median(np.diff(t))
    n = len(t)
    per_segment = n // 4 if segment is None else int(round(segment / dt))
    per_segment = max(8, min(n, per_segment))
    kwargs = dict(fs=1.0 / dt, window="hann", nperseg=per_segment, noverlap=per_segment // 2,
                  detrend="constant", scaling="density", return_onesided=True)
    f, p_v = welch(data[:, 1], **kwargs)
    _, p_a = welch(data[:, 2], **kwargs)
    return f, p_v, p_a, per_segment * dt


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dirs", nargs="+", type=Path)
    parser.add_argument("--segment", type=float, help="Welch segment length [s] (default: window/4)")
    parser.add_argument("--out", type=Path, help="picture (default: the first DIR/spectrum.png)")
    args = parser.parse_intermixed_args()
    directories(args.dirs)

    fig, (ax_v, ax_a) = plt.subplots(2, 1, figsize=(6.5, 6.5), sharex=True)
    for i, run in enumerate(args.dirs):
        summary, data = load(run)
        f, p_v, p_a, seg = spectra(data, args.segment)
        with (run / "spectrum.csv").open("w", newline="") as out:
            w = csv.writer(out, lineterminator="\n")
            w.writerow(["f", "psd_block_velocity", "psd_acoustic"])
            for row in zip(f, p_v, p_a):
                w.writerow([f"{x:.10g}" for x in row])
        label = f"{run.name}: θ = {summary['theta']:.3g}"
        keep = f > 0
        ax_v.loglog(f[keep], p_v[keep], color=f"C{i}", lw=1, label=label)
        ax_a.loglog(f[keep], p_a[keep], color=f"C{i}", lw=1, label=label)
        peak = f[keep][np.argmax(p_v[keep])]
        print(f"{run}: {len(data)} samples over [{data[0, 0]:.6g}, {data[-1, 0]:.6g}] s, "
              f"segments of {seg:.4g} s; block-velocity PSD peaks at {peak:.6g} Hz; "
              f"wrote {run / 'spectrum.csv'}")
    ax_v.set_ylabel("block velocity PSD [(m/s)²/Hz]")
    ax_a.set_ylabel("acoustic PSD [(N/s)²/Hz]")
    ax_a.set_xlabel("frequency [Hz]")
    for ax in (ax_v, ax_a):
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    ax_v.set_title("Welch PSD over each run's averaging window", fontsize=10)
    fig.tight_layout()
    png = args.out or args.dirs[0] / "spectrum.png"
    fig.savefig(png, dpi=130)
    fig.savefig(png.with_suffix(".pdf"))
    print(f"wrote {png} and .pdf")
    return 0


if __name__ == "__main__":
    sys.exit(main())
