"""Sweeps: a sweep file's points, run side by side, as one table."""

import csv
import os
import shutil
import numbers
import warnings
from pathlib import Path

import numpy as np

from . import _core
from ._case import _overrides
from ._core import OutputError
from ._run import Interrupted, MuWarning


def executable():
    """The `stickslip` command a sweep runs its points with: $STICKSLIP_EXECUTABLE,
    else the one built or installed with this module, else the one on PATH."""
    if os.environ.get("STICKSLIP_EXECUTABLE"):
        return Path(os.environ["STICKSLIP_EXECUTABLE"])
    from ._locations import EXECUTABLE  # written by CMake, for the build tree or the install

    here = Path(__file__).resolve().parent
    candidate = (here / EXECUTABLE).resolve()
    if candidate.is_file():
        return candidate
    found = shutil.which("stickslip")
    if found:
        return Path(found)
    raise FileNotFoundError(
        f"no stickslip executable at {candidate} or on PATH; set STICKSLIP_EXECUTABLE"
    )


def _read_csv(path):
    """A CSV table as a pandas DataFrame if pandas is installed, else {column: numpy array}."""
    try:
        import pandas
    except ImportError:
        pandas = None
    if pandas is not None:
        return pandas.read_csv(path)
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, rows = rows[0], rows[1:]
    table = {}
    for i, name in enumerate(header):
        texts = [row[i] for row in rows]
        try:
            table[name] = np.array([float(x) if x else np.nan for x in texts])
        except ValueError:
            table[name] = np.array(texts, dtype=str)
    return table


def load_sweep(dir):
    """The table of the sweep in `dir` (its sweep.csv, a row per point), as
    sweep() returns it: a pandas DataFrame if pandas is installed, else a
    dict of numpy arrays. OutputError if `dir` has no sweep.csv."""
    path = Path(dir) / _core.sweep_file
    if not path.is_file():
        raise OutputError(f"{dir}: no {_core.sweep_file} (not a sweep's directory, or no point has "
                          "finished)")
    return _read_csv(path)


def sweep(path, jobs=None, out=None, set=None, overwrite=False, any_version=False, progress=False):
    """Runs the sweep file at `path` as `stickslip sweep` does (points already
    finished are kept, each point in its own directory under `out`, default
    out/<sweep name>) and returns sweep.csv: a pandas DataFrame if pandas is
    installed, else a dict of numpy arrays. `jobs`: points run at once (default:
    every core); `set`: {"section.key": value} for every point, like --set.
    Failed points are in the table with their status, and warned of; so are
    points whose μ is no friction coefficient (column regime, MuWarning).
    `progress`: a line per point on the process's standard output (a
    terminal's, not a notebook's)."""
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, numbers.Integral) or jobs < 1):
        raise ValueError(f"jobs: expected a positive integer, got {jobs!r}")
    sets = _overrides(set) if set else []
    outcome = _core.sweep(
        Path(path), Path(out) if out is not None else Path(), int(jobs or 0), sets, overwrite,
        any_version, executable(), progress,
    )
    if outcome["interrupted_by"]:
        raise Interrupted(outcome["interrupted_by"], None, Path(outcome["out"]))
    if outcome["failed"]:
        warnings.warn(f"{outcome['failed']} of the sweep's points failed: see their run.log",
                      RuntimeWarning, stacklevel=2)
    table = load_sweep(outcome["out"])
    untrusted = [r for r in table["regime"] if isinstance(r, str) and r not in ("stick-slip", "steady sliding")]
    if untrusted:
        warnings.warn(f"{len(untrusted)} of the sweep's points have a μ that is not a friction coefficient "
                      "(column regime: loading or unsettled): run them longer", MuWarning, stacklevel=2)
    return table
