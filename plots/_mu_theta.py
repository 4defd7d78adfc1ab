"""μ(θ) with error bars over seeds, one curve per other swept value: shared by
fig7.py, fig9.py and epsilon.py. Reads a sweep directory's sweep_summary.csv
(stickslip sweep) and, for what the table does not vary (the lattice, the
drive velocity), its points' summary.json ("case"): titles and legends say what
was run, not what the paper ran."""
import csv
import json
from pathlib import Path

from _command_line import arguments, directories

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COVERAGE = "interface.coverage"


def read_summary(sweep_dir: Path):
    table = sweep_dir / "sweep_summary.csv"
    if not table.is_file():
        raise SystemExit(f"error: {table}: not found (run `stickslip sweep` first)")
    with table.open() as f:
        rows = list(csv.DictReader(f))
    if not rows or COVERAGE not in rows[0]:
        raise SystemExit(f"error: {table}: the sweep does not vary {COVERAGE}")
    return rows


def point_cases(sweep_dir: Path):
    """The case (summary.json's "case") of every finished point of the sweep."""
    cases = []
    for summary in sorted(sweep_dir.glob("*/summary.json")):
        try:
            cases.append(json.loads(summary.read_text())["case"])
        except (OSError, ValueError, KeyError):
            continue  # a point still running, or cut short
    return cases


def case_value(case, key: str):
    """The value of `key` ("section.name") in a case, None if it has none."""
    section, name = key.split(".", 1)
    return case.get(section, {}).get(name)


def lattice(case) -> str:
    size = case.get("lattice", {})
    return "×".join(str(size.get(n, "?")) for n in ("nx", "ny", "nz"))


def number(value) -> str:
    return f"{value:g}" if isinstance(value, (int, float)) else str(value)


def curves(rows, label_key):
    """{label value: [(theta, mean, sd, count, whole_cycles, untrusted, runs_error)]}, sorted by theta;
    points without a result skipped. μ over whole cycles of F_f where the table has it
    (summary.json's mu_whole_cycles: no bias from a fraction of a block-scale cycle), else over
    the window. `untrusted`: how many of the point's runs had a window with neither whole
    cycles nor steady sliding (the loading from rest): their μ is no friction coefficient.
    `runs_error`: the error of the mean from the runs' own error bars (sweep_summary.csv's
    mu_runs_error, or mu_whole_cycles_runs_error with whole cycles), None where a run has none
    or the table predates it."""
    out = {}
    for r in rows:
        if not r["mu_mean"]:
            continue
        key = r.get(label_key, "") if label_key else ""
        cycles = bool(r.get("mu_whole_cycles_mean"))
        prefix = "mu_whole_cycles" if cycles else "mu"
        sd = float(r[prefix + "_std"]) if r[prefix + "_std"] else 0.0
        out.setdefault(key, []).append(
            (float(r["theta_mean"]), float(r[prefix + "_mean"]), sd, int(r["count"]), cycles,
             int(r.get("untrusted") or 0),
             float(r[prefix + "_runs_error"]) if r.get(prefix + "_runs_error") else None))
    for v in out.values():
        v.sort()
    return out


def seed_count(pts) -> str:
    """How many seeds the curve's points average, for its legend: a single seed has no error bar."""
    counts = sorted({p[3] for p in pts})
    n = str(counts[0]) if len(counts) == 1 else f"{counts[0]}–{counts[-1]}"
    return f"{n} seed" + ("" if counts == [1] else "s")


def plot(sweep_dirs, label_key: str, label_name: str, stem: str, title: str) -> int:
    data = {}
    lattices, velocities = set(), set()
    for sweep_dir in sweep_dirs:
        rows = read_summary(sweep_dir)
        cases = point_cases(sweep_dir)
        lattices |= {lattice(c) for c in cases}
        velocities |= {case_value(c, "drive.velocity") for c in cases} - {None}
        key = label_key if label_key and label_key in rows[0] else ""
        # A value the sweep does not vary is its points' (one curve), if they share one.
        fixed = {case_value(c, label_key) for c in cases} if label_key and not key else set()
        for value, pts in curves(rows, key).items():
            if not value and len(fixed) == 1 and None not in fixed:
                value = number(next(iter(fixed)))
            data.setdefault(value, []).extend(pts)
    if lattices:
        title += ", " + ", ".join(sorted(lattices))
    if label_key != "drive.velocity" and len(velocities) == 1:
        title += f", v = {number(next(iter(velocities)))} m/s"
    print(f"title: {title}")
    fig, ax = plt.subplots(figsize=(7, 4))
    for i, (value, pts) in enumerate(sorted(data.items(), key=lambda kv: float(kv[0]) if kv[0] else 0)):
        pts.sort()
        th = [p[0] for p in pts]
        mu = [p[1] for p in pts]
        sd = [p[2] for p in pts]
        label = f"{label_name} = {value}" if value else ""
        label = (label + " " if label else "") + f"({seed_count(pts)})"
        ax.errorbar(th, mu, yerr=sd, marker="o", ms=4, capsize=3, lw=1, color=f"C{i}", label=label)
        # The runs' own error (each μ's window): a thick bar without caps inside the seeds' spread.
        own = [(p[0], p[1], p[6]) for p in pts if p[6] is not None]
        if own:
            ax.errorbar([o[0] for o in own], [o[1] for o in own], yerr=[o[2] for o in own], ls="none",
                        lw=4, alpha=0.35, color=f"C{i}", capsize=0)
        for t, m, s, n, cycles, untrusted, runs_error in pts:
            what = "mu_whole_cycles" if cycles else "mu"
            flag = f" UNTRUSTED in {untrusted} of {n} runs (loading or unsettled window)" if untrusted else ""
            own_text = "" if runs_error is None else f" runs_error={runs_error:.3g}"
            print(f"{label_name}={value or '-'} theta={t:.4g} {what}_mean={m:.6g} {what}_std={s:.3g}{own_text} n={n}{flag}")
    bad = [(p[0], p[1]) for pts in data.values() for p in pts if p[5]]
    if bad:  # a μ from the loading ramp falls as 1/θ: the paper's trend for the wrong reason
        ax.scatter([b[0] for b in bad], [b[1] for b in bad], s=160, facecolors="none", edgecolors="red",
                   lw=1.5, zorder=5, label="not friction: window without whole cycles\nor steady sliding "
                   "(loading); run longer")
    whole = all(p[4] for pts in data.values() for p in pts)
    spread = " (mean ± sd over seeds)" if any(p[3] > 1 for pts in data.values() for p in pts) else ""
    if any(p[6] is not None for pts in data.values() for p in pts):
        ax.plot([], [], lw=4, alpha=0.35, color="gray", label="thick bar: the runs' own error\nof the mean (their windows)")
        if not spread:
            spread = " (thin bar: sd over seeds)"
    ax.set_xlabel("coverage θ")
    ax.set_ylabel(("μ over whole cycles of $F_f$" if whole else "friction coefficient μ") + spread)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))  # beside the axes: no point hidden
    ax.grid(alpha=0.3)
    fig.tight_layout()
    out = sweep_dirs[0]
    for ext in ("png", "pdf"):
        fig.savefig(out / f"{stem}.{ext}", dpi=130)
    print(f"wrote {out / (stem + '.png')} and .pdf")
    return 0


def main(stem: str, title: str, usage: str, label_key: str = "drive.velocity",
         label_name: str = "v (m/s)") -> int:
    """Plots the sweeps on the command line; `title` is completed by the data's
    lattice (and drive velocity, where it is no curve's label)."""
    sweep_dirs = directories(arguments(usage, 1))
    return plot(sweep_dirs, label_key, label_name, stem, title)
