#!/usr/bin/python3
"""μ(θ) at v = 1e-3 m/s for several force scalings ε (cases/epsilon.toml), error bars over seeds.

Usage: /usr/bin/python3 plots/epsilon.py SWEEP_DIR [SWEEP_DIR...]  -> SWEEP_DIR/epsilon.png and epsilon.pdf
"""
import sys

from mu_theta import main

if __name__ == "__main__":
    sys.exit(main("epsilon", "μ(θ) for several ε, v = 1e-3 m/s", "interface.epsilon", "ε"))
