"""Shared by the module's tests: the stickslip command ctest built, the
source tree, and a small case whose two contacts stick and slip."""

import os
import subprocess
from pathlib import Path

import pytest

SOURCE_DIR = Path(os.environ.get("STICKSLIP_SOURCE_DIR", Path(__file__).resolve().parents[2]))
EXECUTABLE = os.environ.get("STICKSLIP_EXECUTABLE", str(SOURCE_DIR / "build" / "stickslip"))

# The two-contact pair of tests/test_restart.cpp on a 6×6×4 lattice: contact
# 0 stick-slips, contact 1 is made to by the coupling; a fraction of a second.
PAIR_TOML = """\
[lattice]
nx = 6
ny = 6
nz = 4
[interface]
contacts = [ { site = [1, 2], v_star = 4.75e-4 }, { site = [4, 2], v_star = 2.09e-3 } ]
[run]
t_end = 1e-3
average_from = 3e-4
[output]
traces = "all"
"""


@pytest.fixture
def pair_file(tmp_path):
    path = tmp_path / "pair.toml"
    path.write_text(PAIR_TOML)
    return path


def cli(*args, cwd=None, check=True):
    """`stickslip ARGS...`; its CompletedProcess (text)."""
    done = subprocess.run([EXECUTABLE, *map(str, args)], cwd=cwd, capture_output=True, text=True)
    if check and done.returncode != 0:
        raise AssertionError(f"stickslip {' '.join(map(str, args))}: {done.returncode}\n{done.stderr}")
    return done
