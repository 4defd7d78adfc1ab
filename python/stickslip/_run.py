"""Runs: one case integrated by the C++ library, and a run's outputs as numpy arrays."""

import json
import shutil
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import _core
from ._case import Case
from ._core import OutputError


@dataclass(frozen=True)
class Friction:
    """friction.csv: the friction force at the output times."""

    t: np.ndarray  # [s]
    F_f: np.ndarray  # [N]
    mu_inst: np.ndarray  # F_f / F_N


@dataclass(frozen=True)
class Traces:
    """traces.csv: in-plane velocities of the traced contacts, [time × contact]."""

    t: np.ndarray  # [s], shape (n,)
    contact: np.ndarray  # contact ids, shape (k,)
    vx: np.ndarray  # [m/s], shape (n, k)
    vy: np.ndarray  # [m/s], shape (n, k)


@dataclass(frozen=True)
class Events:
    """events.csv: every stick/slip transition of the watched contacts, in time
    order. `speed` and `force` say where the transition was located rather
    than measure anything: the speed is κ v* there (to the root finder's
    tolerance), so a single-site contact's force is the same at all of its
    transitions. What changes from slip to slip is in Slips."""

    t: np.ndarray  # [s]
    contact: np.ndarray  # contact id
    kind: np.ndarray  # "slip" or "stick"
    speed: np.ndarray  # [m/s], the contact's speed |s| at the transition: κ v*
    force: np.ndarray  # [N], its contact law's force |F| at that speed


@dataclass(frozen=True)
class Slips:
    """slips.csv, the event catalogue: one row per slip of a watched contact,
    from its slip event to its next stick event, in the order the slips end.
    A slip under way at t = 0 or still going at t_end has no row."""

    t_start: np.ndarray  # [s], the slip event
    t_end: np.ndarray  # [s], the stick event that ends it
    contact: np.ndarray  # contact id
    duration: np.ndarray  # [s], t_end - t_start
    slip: np.ndarray  # [m], |u(t_end) - u(t_start)|, u the contact's in-plane displacement
    peak_speed: np.ndarray  # [m/s], the largest |s| sampled in between (README)
    load_start: np.ndarray  # [N], |force of the block on the contact| at t_start
    load_end: np.ndarray  # [N], the same at t_end
    load_drop: np.ndarray  # [N], load_start - load_end
    F_f_start: np.ndarray  # [N], the block's friction force F_f at t_start
    F_f_end: np.ndarray  # [N], F_f at t_end
    F_f_drop: np.ndarray  # [N], F_f_start - F_f_end


@dataclass(frozen=True)
class Contacts:
    """contacts.csv: where each contact is (a patch's corner) and its v*."""

    id: np.ndarray
    ix: np.ndarray
    iy: np.ndarray
    v_star: np.ndarray  # [m/s]


@dataclass(frozen=True)
class Run:
    """A run's results. `summary` is summary.json as a dict (None while a run
    is unfinished); `traces`, `events` and `slips` are None when the case did
    not ask for them (`slips` also for a run written before slips.csv
    existed); `tables` holds the other tables it asked for (steps, signals,
    final_state) as {column: array}; `dir` is where its files are (None for a
    run made without `out`)."""

    summary: dict | None
    friction: Friction
    contacts: Contacts
    traces: Traces | None = None
    events: Events | None = None
    slips: Slips | None = None
    tables: dict = field(default_factory=dict)
    dir: Path | None = None

    @property
    def mu(self):
        """The time-averaged friction coefficient (summary["mu"]); None if unfinished."""
        return None if self.summary is None else self.summary["mu"]

    @property
    def mu_trusted(self):
        """Whether μ is a friction coefficient: its window holds whole slip cycles
        or steady sliding (summary["regime"]); None if unfinished or not judged."""
        regime = None if self.summary is None else self.summary.get("regime")
        return None if regime is None else regime["mu_trusted"]


class AccuracyWarning(UserWarning):
    """Something summary.json's "warnings" says a user of the result must know
    (e.g. an rtol too loose to trust slip counts and times)."""


class MuWarning(AccuracyWarning):
    """A run's μ is not a friction coefficient: its averaging window holds no
    whole slip cycle and no steady sliding (summary["regime"]), e.g. the
    elastic loading from rest."""


class Interrupted(KeyboardInterrupt):
    """SIGINT (Ctrl-C) or SIGTERM stopped a run at an output time, after its
    outputs were flushed and, with `out`, a checkpoint written there."""

    def __init__(self, signal, t, out):
        self.signal, self.t, self.out = signal, t, out
        if t is None:  # a sweep
            super().__init__(f"sweep interrupted; points finished so far are in {out}: "
                             "run the sweep again to continue")
            return
        if out is None:
            where = "no checkpoint kept (the run had no `out`)"
        else:
            where = (
                f"a checkpoint in {out}: continue with stickslip.run(case, out={str(out)!r}, "
                f"restart=True) or `stickslip run CASE --restart {out}`"
            )
        super().__init__(f"interrupted at t = {t:.9g} s; {where}")

    def __reduce__(self):  # so that it crosses a process pool
        return (Interrupted, (self.signal, self.t, self.out))


def load(dir):
    """The outputs of the run in `dir` (CSV or run.h5, finished or still
    running) as a Run. OutputError if `dir` holds no run."""
    dir = Path(dir)
    if not _core.has_table(dir, "friction"):
        raise OutputError(f"{dir}: holds no run (no friction.csv or run.h5)")
    text = _core.read_summary(dir)
    summary = None if text is None else json.loads(text)
    f = dict(_core.read_columns(dir, "friction"))
    c = dict(_core.read_columns(dir, "contacts"))
    contacts = Contacts(
        id=c["id"].astype(np.int64),
        ix=c["ix"].astype(np.int64),
        iy=c["iy"].astype(np.int64),
        v_star=c["v_star"],
    )
    traces = None
    if _core.has_table(dir, "traces"):
        columns = dict(_core.read_columns(dir, "traces"))  # t, vx_<id>, vy_<id>, ...
        ids = [int(name[3:]) for name in columns if name.startswith("vx_")]
        t = columns["t"]
        traces = Traces(
            t=t,
            contact=np.array(ids, dtype=np.int64),
            vx=np.stack([columns[f"vx_{i}"] for i in ids], axis=1) if ids else np.empty((t.size, 0)),
            vy=np.stack([columns[f"vy_{i}"] for i in ids], axis=1) if ids else np.empty((t.size, 0)),
        )
    events = None
    if _core.has_table(dir, "events"):
        e = _core.read_events(dir)
        events = Events(
            t=e["t"], contact=e["contact"], kind=np.array(e["kind"], dtype=str), speed=e["speed"],
            force=e["force"],
        )
    slips = None
    if _core.has_table(dir, "slips"):
        c = dict(_core.read_columns(dir, "slips"))
        c["contact"] = c["contact"].astype(np.int64)
        slips = Slips(**{name: c[name] for name in Slips.__dataclass_fields__})
    typed = ("friction", "contacts", "traces", "events", "slips")
    tables = {name: dict(_core.read_columns(dir, name)) for name in _core.recorder_tables()
              if name not in typed and _core.has_table(dir, name)}
    return Run(
        summary=summary,
        friction=Friction(f["t"], f["F_f"], f["mu_inst"]),
        contacts=contacts,
        traces=traces,
        events=events,
        slips=slips,
        tables=tables,
        dir=dir,
    )


def run(case, out=None, progress=False, overwrite=False, restart=False,
        any_version=False):
    """Integrates `case` (a Case, or a case file's path) and returns its Run.

    Without `out` the outputs go to a temporary directory that is removed
    once they are read (nothing is left on disk; [output] dir is not used).
    With `out`, its usual outputs are written there as `stickslip run --out`
    writes them, and stay; `overwrite` replaces an earlier run's results
    there, and `restart` continues the interrupted run there from its
    checkpoint (one written by another code version only with
    `any_version`; summary["provenance"]["segments"] lists each attempt's). `progress` shows the command line's progress line on stderr
    (when stderr is a terminal).

    `case` may also be a dict, as Case.from_dict takes it.

    The run releases the GIL, so runs in threads go side by side; give
    such runs [solver] threads = 1 (the default, 0, gives each run every
    core, and runs side by side would oversubscribe them). Ctrl-C
    (SIGINT) or SIGTERM stops every run of the process at its next output
    time, each raising Interrupted (a KeyboardInterrupt). A μ whose window
    is the loading ramp, or less than a cycle, is warned of (MuWarning) and
    flagged in summary["regime"]. Raises CaseError or
    OutputError for bad input, IntegrationError when the integration or its
    energy audit fails.
    """
    if isinstance(case, dict):
        case = Case.from_dict(case)
    elif isinstance(case, (str, Path)) or hasattr(case, "__fspath__"):
        case = Case.from_toml(case)
    elif not isinstance(case, Case):
        raise TypeError(f"expected a Case, a case file's path or a dict, got {type(case).__name__}")
    temporary = out is None
    if restart and temporary:
        raise OutputError("restart=True needs `out`: the directory of the interrupted run")
    if any_version and not restart:
        raise OutputError("any_version=True applies to restart=True only")
    dir = Path(tempfile.mkdtemp(prefix="stickslip-run-")) if temporary else Path(out)
    try:
        outcome = _core.run(case._case, dir, overwrite, restart, any_version, not progress)
        if not isinstance(outcome, str):
            _, signal, t = outcome
            raise Interrupted(signal, t, None if temporary else dir)
        result = load(dir)
        for w in result.summary.get("warnings", []):
            warnings.warn(w["text"], MuWarning if w["about"] == "mu" else AccuracyWarning, stacklevel=2)
        return Run(**{**result.__dict__, "dir": None}) if temporary else result
    finally:
        if temporary:
            shutil.rmtree(dir, ignore_errors=True)
