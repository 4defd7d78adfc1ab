#!/usr/bin/python3
"""The paper's Fig. 7: μ(θ) at v = 3e-4 and 1e-3 m/s (on 15×15×10 in the paper), error bars over seeds.

Usage: /usr/bin/python3 plots/fig7.py SWEEP_DIR [SWEEP_DIR...]   (the outputs of `stickslip sweep cases/fig7.toml` and cases/fig7_slow.toml)
       -> the first SWEEP_DIR/fig7.png and fig7.pdf; the title names the lattice the sweeps ran
"""
import sys

from _mu_theta import main

if __name__ == "__main__":
    sys.exit(main("fig7", "Fig. 7: μ(θ)", __doc__))
