#!/usr/bin/python3
"""μ(θ) for several force scalings ε (cases/epsilon.toml, v = 1e-3 m/s), error bars over seeds.

Usage: /usr/bin/python3 plots/epsilon.py SWEEP_DIR [SWEEP_DIR...]
       -> the first SWEEP_DIR/epsilon.png and epsilon.pdf; the title names the lattice and v the sweeps ran
"""
import sys

from _mu_theta import main

if __name__ == "__main__":
    sys.exit(main("epsilon", "μ(θ) for several ε", __doc__, "interface.epsilon", "ε"))
