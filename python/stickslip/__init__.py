"""stickslip from Python: an elastic block sliding on stick-slip contacts.

    import stickslip
    case = stickslip.Case.from_dict({"lattice": {"nx": 6, "ny": 6, "nz": 4},
                                     "run": {"t_end": 10e-3, "average_from": 5e-3}})
    run = stickslip.run(case.replace({"drive.velocity": 3e-4}))
    run.summary["mu"], run.friction.t, run.friction.mu_inst
    run.friction.to_pandas(), run.to_xarray()

The physics and the numerics are the C++ library the command line uses
(`stickslip._core`); this package turns cases, runs and their tables into
Python objects and numpy arrays. docs/USAGE.md, "Python", says more.
"""

from ._case import Case
from ._core import CaseError, IntegrationError, OutputError, git_commit
from ._core import version as __version__
from ._run import AccuracyWarning, Contacts, Events, Friction, Interrupted, MuWarning, Run, Slips, Traces, load, run
from ._sweep import load_sweep, sweep

__all__ = [
    "AccuracyWarning",
    "Case",
    "CaseError",
    "Contacts",
    "Events",
    "Friction",
    "IntegrationError",
    "Interrupted",
    "MuWarning",
    "OutputError",
    "Run",
    "Slips",
    "Traces",
    "git_commit",
    "load",
    "load_sweep",
    "run",
    "sweep",
]
