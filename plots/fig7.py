#!/usr/bin/python3
"""The paper's Fig. 7: μ(θ) on 15×15×10 at v = 3e-4 and 1e-3 m/s, error bars over seeds.

Usage: /usr/bin/python3 plots/fig7.py SWEEP_DIR [SWEEP_DIR...]   (the outputs of `stickslip sweep cases/fig7.toml` and cases/fig7_slow.toml)
       -> SWEEP_DIR/fig7.png and fig7.pdf
"""
import sys

from mu_theta import main

if __name__ == "__main__":
    sys.exit(main("fig7", "Fig. 7: μ(θ), 15×15×10"))
