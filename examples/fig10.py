#!/usr/bin/python3
"""The paper's Fig. 10 from Python: two contacts (v* = 4.75e-4 and 2.09e-3 m/s)
one lattice constant apart (a: they slip together) and seven apart (b: each
stick-slips on its own), their x-velocities against time.

Usage: PYTHONPATH=build/python /usr/bin/python3 examples/fig10.py [PNG]

writes PNG (default fig10.png); about 25 s on 2 cores (two runs, 13 s of CPU time).
"""
import sys

if "-h" in sys.argv[1:] or "--help" in sys.argv[1:]:
    print(__doc__.strip())
    sys.exit(0)

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import stickslip  # noqa: E402

# cases/fig10b.toml, as a dict: the paper's 15×15×10 lattice and parameters
# are the defaults; only the two contacts, the run and the traces are given.
fig10b = stickslip.Case.from_dict({
    "interface": {"contacts": [{"site": [4, 7], "v_star": 4.75e-4},
                               {"site": [11, 7], "v_star": 2.09e-3}]},
    "drive": {"velocity": 1e-3},
    "run": {"t_end": 3e-3, "average_from": 1e-3},
    "output": {"interval": 1e-6, "traces": "all"},
})
# (a): contact 1 moved next to contact 0.
fig10a = fig10b.replace({"interface.contacts": [{"site": [4, 7], "v_star": 4.75e-4},
                                                {"site": [5, 7], "v_star": 2.09e-3}]})

fig, axes = plt.subplots(2, 2, figsize=(10, 6), sharex=True, constrained_layout=True)
for column, (label, case) in enumerate([("(a) one apart", fig10a), ("(b) seven apart", fig10b)]):
    run = stickslip.run(case)
    s = run.summary
    how = (f"{s['solver']['method']}, rtol {s['solver']['rtol']:g}, "
           f"{s['solver_stats']['steps']} steps, energy residual {s['energy_residual']:.1e}")
    print(f"{label}: mu = {run.mu:.6f}  ({how}, {s['wall_seconds']:.1f} s)")
    for row, contact in enumerate(run.traces.contact):
        ax = axes[row, column]
        ax.plot(run.traces.t * 1e3, run.traces.vx[:, row] * 1e3, lw=0.8)
        ax.axhline(case.to_dict()["drive"]["velocity"] * 1e3, color="grey", lw=0.5, ls="--")
        v_star = run.contacts.v_star[contact]
        ax.set_title(f"{label}: contact {contact}, v* = {v_star * 1e3:.3g} mm/s", fontsize=10)
        ax.set_ylabel("$v_x$ [mm/s]")
    axes[1, column].set_xlabel("t [ms]")
    axes[0, column].text(0.01, 0.97, f"μ = {run.mu:.4f}\n{how}", transform=axes[0, column].transAxes,
                         va="top", fontsize=7)
png = sys.argv[1] if len(sys.argv) > 1 else "fig10.png"
fig.savefig(png, dpi=120)
print(f"plot: {png}")
