#!/usr/bin/python3
"""The paper's Fig. 9: μ(θ) at v = 4e-4, 7e-4 and 1e-3 m/s (on 30×30×10 in the paper), error bars over seeds.

Usage: /usr/bin/python3 plots/fig9.py SWEEP_DIR [SWEEP_DIR...]   (the outputs of `stickslip sweep cases/fig9.toml`)
       -> the first SWEEP_DIR/fig9.png and fig9.pdf; the title names the lattice the sweeps ran
"""
import sys

from _mu_theta import main

if __name__ == "__main__":
    sys.exit(main("fig9", "Fig. 9: μ(θ)", __doc__))
