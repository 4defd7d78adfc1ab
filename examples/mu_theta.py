#!/usr/bin/python3
"""A small μ(θ) curve from Python (the paper's Fig. 7 in miniature): μ against
the contact density θ on a 10×10×6 block at v = 1 mm/s, two seeds per θ, the
runs side by side in threads (a run releases the GIL).

Usage: PYTHONPATH=build/python /usr/bin/python3 examples/mu_theta.py [PNG]

writes PNG (default mu_theta.png); about a minute on two cores. On a block
this small and this short the numbers are rough (docs/RESULTS.md has the
paper's sizes); the point is the few lines it takes.
"""
import os
import sys
from concurrent.futures import ThreadPoolExecutor

if "-h" in sys.argv[1:] or "--help" in sys.argv[1:]:
    print(__doc__.strip())
    sys.exit(0)

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import stickslip  # noqa: E402

base = stickslip.Case.from_dict({
    "lattice": {"nx": 10, "ny": 10, "nz": 6},
    "drive": {"velocity": 1e-3},
    "run": {"t_end": 10e-3, "average_from": 2e-3},
    # One thread per run: the runs go side by side, one per core.
    "solver": {"rtol": 1e-5, "threads": 1},
    "output": {"events": "none"},  # no root finding: only μ is wanted
})
thetas = [0.04, 0.1, 0.2, 0.35, 0.5]
seeds = [1, 2]
cases = [base.replace({"interface.coverage": theta, "interface.seed": seed})
         for theta in thetas for seed in seeds]
with ThreadPoolExecutor(max_workers=os.cpu_count()) as pool:
    runs = list(pool.map(stickslip.run, cases))


def mu(run):
    """μ over whole cycles of F_f where the window holds some, else over the window."""
    whole = run.summary.get("mu_whole_cycles")
    return whole["mu"] if whole else run.mu


mus = np.array([mu(r) for r in runs]).reshape(len(thetas), len(seeds))
measured_theta = np.array([r.summary["theta"] for r in runs]).reshape(len(thetas), len(seeds))
for theta, row, run in zip(measured_theta[:, 0], mus, runs[:: len(seeds)]):
    s = run.summary
    print(f"theta = {theta:.3f}: mu = {row.mean():.4f} +- {row.std(ddof=1):.4f}  "
          f"({s['solver']['method']}, rtol {s['solver']['rtol']:g}, residual {s['energy_residual']:.1e})")

fig, ax = plt.subplots(figsize=(5, 3.6), constrained_layout=True)
ax.errorbar(measured_theta[:, 0], mus.mean(axis=1), yerr=mus.std(axis=1, ddof=1), marker="o",
            capsize=3, label=f"10×10×6, v = 1 mm/s, {len(seeds)} seeds")
ax.set_xlabel("θ (contact density)")
ax.set_ylabel("μ")
ax.set_title(f"μ(θ), {s['solver']['method']} at rtol {s['solver']['rtol']:g}, μ over 2–10 ms", fontsize=10)
ax.legend(fontsize=8)
png = sys.argv[1] if len(sys.argv) > 1 else "mu_theta.png"
fig.savefig(png, dpi=120)
print(f"plot: {png}")
