#!/usr/bin/python3
"""Where a block slip starts and how it spreads over the contacts: the map of
one block slip of a run with events (`[output] events = "all"`).

Usage: /usr/bin/python3 plots/block_slip_map.py RUN_DIR [RUN_DIR ...] [--slip N] [--movie]
  -> RUN_DIR/block_slip_map.png and .pdf: the contacts on the x-y plane
     coloured by when each first slips in block slip N (µs after its first
     slip's onset; the contacts that do not slip in it hollow), the first-slip
     times against the distance from the nucleating contact with the fitted
     front speed, and F_f around the block slip with its onset and end marked;
     one line per run on stdout: which block slip, how many contacts slipped
     in it, where it nucleated and the front speed with its fit's standard
     error.
  --slip N   which block slip: 0-based among those wholly in the averaging
             window, as plots/block_slips.py counts them (default 0, the first)
  --movie    also RUN_DIR/block_slip_<N>.gif: the contacts' speeds over the
             block slip, a frame per row of traces.csv (needs
             `[output] traces = "all"` and Pillow, Debian's python3-pil)

The block slip and its slips are the census's (plots/block_slips.py): the
slips chained in time through F_f's drop. A contact's first-slip time is the
earliest onset among its slips in the chain; the nucleating contact is the one
that slips first, and the block slip's onset is its first slip. The front
speed is 1/slope of a least-squares line of the other contacts' first-slip
times against their distance from the nucleating contact: on the periodic
lattice the shortest (minimum-image) distance on the nx x ny torus, in
lattice spacings times the case's lattice.spacing; a patch (interface.patch
> 1) sits at its centre. The nucleating contact itself is left out of the fit:
it often slips alone for tens of µs before the front leaves its neighbourhood
(a precursor), and its point at distance 0 would tilt the line. The speed's
standard error is the slope's, propagated (se/slope²). The colour scale
starts at the earliest of the other contacts, so that the front's spread is
seen; the nucleating contact, earlier, is drawn below it (darkest).
"""
import importlib.util
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from block_slips import census, fail  # noqa: E402
from _command_line import arguments, directories  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402
from run_tables import read_table, where  # noqa: E402
from scipy.stats import linregress  # noqa: E402

USAGE = __doc__.split("\n\n")[1]


def options(args):
    """(run directories, slip index, movie?) from the command line."""
    runs, slip, movie = [], 0, False
    i = 0
    while i < len(args):
        a = args[i]
        if a == "--movie":
            movie = True
        elif a == "--slip" or a.startswith("--slip="):
            if a == "--slip":
                i += 1
                value = args[i] if i < len(args) else ""
            else:
                value = a.split("=", 1)[1]
            if not value.isdigit():
                fail(f"--slip takes a block slip's 0-based index, not {value!r}")
            slip = int(value)
        elif a.startswith("-"):
            print(USAGE.strip(), file=sys.stderr)
            raise SystemExit(2)
        else:
            runs.append(a)
        i += 1
    if not runs:
        print(USAGE.strip(), file=sys.stderr)
        raise SystemExit(2)
    return runs, slip, movie


def require_slips(run: Path):
    """Fail unless the run located every contact's slips (slips.csv)."""
    if not (run / "summary.json").is_file():
        fail(f"{run / 'summary.json'}: not found (not a finished run's directory)")
    events = json.loads((run / "summary.json").read_text())["case"]["output"]["events"]
    if events != "all":
        fail(f"{run}: no slips of every contact ([output] events = {json.dumps(events)}); the map "
             "needs them: run the case with [output] events = \"all\"")
    if read_table(run, "slips") is None:
        fail(f"{run}: no slips ({where(run, 'slips')} not found); the map needs every contact's: "
             "run the case with [output] events = \"all\"")


def require_movie(run: Path, summary, contacts):
    """Pillow to write the GIF, and every contact's trace (returned); else fail."""
    if importlib.util.find_spec("PIL") is None:  # matplotlib's PillowWriter needs it
        fail("--movie writes its GIF with Pillow, which is not installed: install Debian's "
             "python3-pil (apt-get install python3-pil)")
    traces = read_table(run, "traces")
    if traces is None or any(f"vx_{c}" not in traces for c in contacts["id"].astype(int)):
        fail(f"{run}: --movie needs every contact's speed ({where(run, 'traces')}, [output] traces = "
             f"{json.dumps(summary['case']['output']['traces'])}); run the case with [output] traces = \"all\"")
    return traces


def lattice_of(summary):
    """(nx, ny, spacing [m], patch size R) of the run's case."""
    lattice = summary["case"]["lattice"]
    patch = int(summary["case"].get("interface", {}).get("patch", 1) or 1)
    return lattice["nx"], lattice["ny"], lattice["spacing"], max(patch, 1)


def torus_distance(x0, y0, x, y, nx, ny):
    """The shortest distance from (x0, y0) to (x, y) on the periodic nx x ny lattice, in spacings."""
    dx = np.abs(np.asarray(x) - x0) % nx
    dy = np.abs(np.asarray(y) - y0) % ny
    return np.hypot(np.minimum(dx, nx - dx), np.minimum(dy, ny - dy))


def front(distance, delay):
    """Front speed and its standard error from first-slip delays [s] against distances [m]:
    (speed, se), nan where fewer than 3 contacts or no outward spreading (slope <= 0)."""
    if len(distance) < 3 or np.ptp(distance) == 0:
        return float("nan"), float("nan"), None
    fit = linregress(distance, delay)
    if fit.slope <= 0:
        return float("nan"), float("nan"), fit
    return 1 / fit.slope, fit.stderr / fit.slope**2, fit


def grid_of(values, contacts, nx, ny, patch):
    """An ny x nx image of `values` (one per contact) on the contacts' cells, NaN elsewhere."""
    grid = np.full((ny, nx), np.nan)
    for v, ix, iy in zip(values, contacts["ix"].astype(int), contacts["iy"].astype(int)):
        for dx in range(patch):
            for dy in range(patch):
                grid[(iy + dy) % ny, (ix + dx) % nx] = v
    return grid


def draw_lattice(ax, nx, ny, a_mm):
    ax.set_xlim(-0.5 * a_mm, (nx - 0.5) * a_mm)
    ax.set_ylim(-0.5 * a_mm, (ny - 0.5) * a_mm)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")


def hollow(ax, contacts, keep, nx, ny, patch, a_mm):
    """The contacts in `keep` as grey outlines of their cells."""
    for ix, iy in zip(contacts["ix"][keep].astype(int), contacts["iy"][keep].astype(int)):
        for dx in range(patch):
            for dy in range(patch):
                x, y = (ix + dx) % nx, (iy + dy) % ny
                ax.add_patch(Rectangle(((x - 0.45) * a_mm, (y - 0.45) * a_mm), 0.9 * a_mm,
                                       0.9 * a_mm, fill=False, ec="0.55", lw=0.8))


def block_slip(run: Path, n: int):
    """Everything the map needs of block slip n of the run."""
    require_slips(run)
    summary, friction, rows, _, _, _ = census(run)
    if n >= len(rows):
        window = f"[{summary['average_from']:g}, {friction['t'][-1]:g}] s"
        fail(f"{run}: no block slip {n}: the run has {len(rows)} block slip"
             f"{'' if len(rows) == 1 else 's'} wholly in its window {window} (--slip counts from 0)")
    row = rows[n]
    slips = read_table(run, "slips")
    members = row["members"]
    contacts = read_table(run, "contacts")
    if contacts is None:
        fail(f"{where(run, 'contacts')}: not found (the map needs the contacts' sites)")
    ids = contacts["id"].astype(int)
    start, contact = slips["t_start"][members], slips["contact"][members].astype(int)
    first = {}
    for t, c in zip(start, contact):
        first[c] = min(t, first.get(c, np.inf))
    t_first = np.array([first.get(c, np.nan) for c in ids])  # per contact, NaN: no slip in it
    k0 = int(np.nanargmin(t_first))
    nx, ny, a, patch = lattice_of(summary)
    centre = (patch - 1) / 2
    x, y = contacts["ix"] + centre, contacts["iy"] + centre
    distance = a * torus_distance(x[k0], y[k0], x, y, nx, ny)  # [m]
    slipped = ~np.isnan(t_first)
    others = slipped & (np.arange(len(ids)) != k0)
    speed, se, fit = front(distance[others], t_first[others] - row["first"])
    return {"summary": summary, "friction": friction, "row": row, "contacts": contacts,
            "t_first": t_first, "onset": row["first"], "k0": k0, "nucleus": int(ids[k0]),
            "x": x, "y": y, "distance": distance, "slipped": slipped, "others": others,
            "speed": speed, "se": se, "fit": fit}


def plot_map(path: Path, run: Path, n: int, b):
    summary, friction, row, contacts = b["summary"], b["friction"], b["row"], b["contacts"]
    onset, k0, nucleus, x, y = b["onset"], b["k0"], b["nucleus"], b["x"], b["y"]
    slipped, others, speed, se, fit = b["slipped"], b["others"], b["speed"], b["se"], b["fit"]
    nx, ny, a, patch = lattice_of(summary)
    a_mm = 1e3 * a
    delay_us = 1e6 * (b["t_first"] - onset)
    ids = contacts["id"].astype(int)
    distance_mm = 1e3 * b["distance"]

    fig = plt.figure(figsize=(11, 5.2))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.15, 1), hspace=0.45, wspace=0.28)
    ax_map = fig.add_subplot(grid[:, 0])
    ax_f = fig.add_subplot(grid[0, 1])
    ax_fit = fig.add_subplot(grid[1, 1])

    # The map: a cell per contact node, its colour the first slip's delay.
    # The scale starts at the other contacts' earliest: the nucleus, often a
    # precursor tens of µs ahead, would squeeze the front into one colour.
    cmap = plt.get_cmap("viridis").copy()
    cmap.set_under("black")
    low = np.nanmin(delay_us[others]) if others.any() else 0.0
    high = np.nanmax(delay_us[slipped])
    image = ax_map.imshow(grid_of(delay_us, contacts, nx, ny, patch), origin="lower", cmap=cmap,
                          vmin=low, vmax=max(high, low + 1e-3),
                          extent=(-0.5 * a_mm, (nx - 0.5) * a_mm, -0.5 * a_mm, (ny - 0.5) * a_mm),
                          interpolation="nearest")
    hollow(ax_map, contacts, ~slipped, nx, ny, patch, a_mm)
    ax_map.plot(x[k0] * a_mm, y[k0] * a_mm, marker="*", ms=14, mfc="none", mec="red", mew=1.5,
                ls="none")
    draw_lattice(ax_map, nx, ny, a_mm)
    bar = fig.colorbar(image, ax=ax_map, fraction=0.046, pad=0.03,
                       extend="min" if low > 0 else "neither")
    bar.set_label("first slip (µs after onset)")
    ax_map.set_title(f"{slipped.sum()} of {len(ids)} contacts slip"
                     + ("" if slipped.all() else " (hollow: do not)")
                     + f"; red star: the first, contact {nucleus}", fontsize=9)

    # F_f around the block slip, its onset (first slip) and end (last arrest) marked.
    last = row["last"]
    span = last - onset
    keep = (friction["t"] >= onset - span) & (friction["t"] <= last + span)
    ax_f.plot(1e6 * (friction["t"][keep] - onset), 1e3 * friction["F_f"][keep], lw=1, color="C0")
    ax_f.axvline(0, color="C3", lw=0.8, ls="--", label="onset (first slip)")
    ax_f.axvline(1e6 * span, color="0.3", lw=0.8, ls=":", label="end (last arrest)")
    ax_f.set_xlabel("t − onset (µs)")
    ax_f.set_ylabel("$F_f$ (mN)")
    ax_f.set_title(f"friction force: onset at {1e3 * onset:.4f} ms, lasting {1e6 * span:.0f} µs",
                   fontsize=9)
    ax_f.legend(fontsize=7, loc="best")

    # The rupture front: first-slip delay against distance from the nucleus.
    ax_fit.plot(distance_mm[others], delay_us[others], "o", ms=3, color="C0",
                label="the other contacts that slip")
    ax_fit.plot(0, 0, marker="*", ms=11, mfc="none", mec="red", mew=1.2, ls="none",
                label=f"the first, contact {nucleus} (not fitted)")
    if fit is not None:
        d = np.linspace(distance_mm[others].min(), distance_mm[others].max(), 2)
        # fit is in s against m: delay [µs] = 1e6 (intercept + slope d[mm] 1e-3)
        ax_fit.plot(d, 1e6 * (fit.intercept + fit.slope * 1e-3 * d), color="C3", lw=1.2,
                    label=(f"front {speed:.3g} ± {se:.2g} m/s" if np.isfinite(speed)
                           else "no outward front (slope ≤ 0)"))
    ax_fit.set_xlabel("distance from the first contact (mm, periodic)")
    ax_fit.set_ylabel("first slip (µs after onset)")
    ax_fit.legend(fontsize=7, loc="best")

    lattice = summary["case"]["lattice"]
    fig.suptitle(f"{run.resolve().name}: block slip {n} ({lattice['nx']}×{lattice['ny']}×"
                 f"{lattice['nz']}, θ = {summary['theta']:.3g})", fontsize=11)
    fig.subplots_adjust(left=0.06, right=0.97, top=0.88, bottom=0.11)
    fig.savefig(path, dpi=100)
    fig.savefig(path.with_suffix(".pdf"))
    plt.close(fig)


def movie(path: Path, run: Path, n: int, b, traces):
    """The contacts' in-plane speeds over the block slip, a frame per traced row."""
    from matplotlib.animation import PillowWriter

    summary, row, contacts, onset = b["summary"], b["row"], b["contacts"], b["onset"]

    nx, ny, a, patch = lattice_of(summary)
    a_mm = 1e3 * a
    span = row["last"] - onset
    t = traces["t"]
    rows = np.flatnonzero((t >= onset - 0.1 * span) & (t <= row["last"] + 0.1 * span))
    if len(rows) > 300:  # a GIF of a few hundred frames at most
        rows = rows[:: int(np.ceil(len(rows) / 300))]
    ids = contacts["id"].astype(int)
    speed = np.array([np.hypot(traces[f"vx_{c}"][rows], traces[f"vy_{c}"][rows]) for c in ids])
    low = 0.1 * summary["case"]["drive"]["velocity"]
    high = max(speed.max(), 10 * low)
    cmap = plt.get_cmap("plasma").copy()
    cmap.set_under("0.8")

    fig, ax = plt.subplots(figsize=(5.4, 4.6))
    image = ax.imshow(grid_of(speed[:, 0], contacts, nx, ny, patch), origin="lower", cmap=cmap,
                      norm=LogNorm(vmin=low, vmax=high), interpolation="nearest",
                      extent=(-0.5 * a_mm, (nx - 0.5) * a_mm, -0.5 * a_mm, (ny - 0.5) * a_mm))
    draw_lattice(ax, nx, ny, a_mm)
    bar = fig.colorbar(image, ax=ax, extend="min")
    bar.set_label("contact speed |v| (m/s)")
    title = ax.set_title("", fontsize=9)
    fig.tight_layout()

    # The writer grabs each frame once (FuncAnimation.save would draw each twice).
    writer = PillowWriter(fps=12)
    with writer.saving(fig, path, dpi=80):
        for k in range(len(rows)):
            image.set_data(grid_of(speed[:, k], contacts, nx, ny, patch))
            title.set_text(f"{run.resolve().name}: block slip {n}, t − onset = "
                           f"{1e6 * (t[rows[k]] - onset):.1f} µs")
            writer.grab_frame()
    plt.close(fig)
    return len(rows)


def main():
    args, n, want_movie = options(arguments(USAGE, 1))
    for run in directories(args):
        b = block_slip(run, n)
        traces = require_movie(run, b["summary"], b["contacts"]) if want_movie else None
        png = run / "block_slip_map.png"
        plot_map(png, run, n, b)
        wrote = f"{png}"
        if want_movie:
            gif = run / f"block_slip_{n}.gif"
            frames = movie(gif, run, n, b, traces)
            wrote += f" and {gif} ({frames} frames)"
        speed, se, contacts, k0, row = b["speed"], b["se"], b["contacts"], b["k0"], b["row"]
        front_text = (f"front speed {speed:.4g} ± {se:.2g} m/s over {int(b['others'].sum())} contacts"
                      if np.isfinite(speed) else
                      "no front speed (fewer than 3 other contacts, or none spreading outward)")
        print(f"{run}: block slip {n} ({1e3 * b['onset']:.4f}–{1e3 * row['last']:.4f} ms): "
              f"{int(b['slipped'].sum())} of {len(contacts['id'])} contacts slipped, the first "
              f"contact {b['nucleus']} at ({int(contacts['ix'][k0])}, {int(contacts['iy'][k0])}) "
              f"{1e6 * (np.nanmin(b['t_first'][b['others']]) - b['onset']) if b['others'].any() else float('nan'):.1f} µs "
              f"ahead of the next; {front_text}; wrote {wrote}")


if __name__ == "__main__":
    sys.exit(main())
