"""Runs: one case integrated by the C++ library, and a run's outputs as numpy arrays."""

import errno
import json
import numbers
import shutil
import sys
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import _core
from ._case import Case
from ._core import OutputError


class _Table(dict):
    """A table's columns, also a read-only dict {CSV column name: numpy array},
    so that pandas.DataFrame(table) and table.to_pandas() give the CSV's
    table; the fields are attributes (table.t). Its repr is its shape."""

    def __post_init__(self):
        dict.update(self, self._columns())

    def _columns(self):
        return {name: getattr(self, name) for name in self.__dataclass_fields__}

    def _read_only(self, *args, **kwargs):
        raise TypeError(f"{type(self).__name__} is read-only")

    __setitem__ = __delitem__ = update = pop = popitem = clear = setdefault = __ior__ = _read_only

    def __reduce__(self):  # pickled by its fields (not as a dict: that would go through __setitem__)
        return (type(self), tuple(getattr(self, name) for name in self.__dataclass_fields__))

    def to_pandas(self):
        """The table as a pandas DataFrame, columns named as in the CSV file."""
        import pandas

        return pandas.DataFrame(dict(self))

    def __repr__(self):
        rows = len(next(iter(self.values()))) if self else 0
        return f"{type(self).__name__}({rows} rows: {', '.join(self)})"


@dataclass(frozen=True, repr=False)
class Friction(_Table):
    """friction.csv: the friction force at the output times."""

    t: np.ndarray  # [s]
    F_f: np.ndarray  # [N]
    mu_inst: np.ndarray  # F_f / F_N


@dataclass(frozen=True, repr=False)
class Traces(_Table):
    """traces.csv: in-plane velocities of the traced contacts, [time × contact].
    As a dict (and a DataFrame) it is the CSV's columns: t, vx_<id>, vy_<id>, ..."""

    t: np.ndarray  # [s], shape (n,)
    contact: np.ndarray  # contact ids, shape (k,)
    vx: np.ndarray  # [m/s], shape (n, k)
    vy: np.ndarray  # [m/s], shape (n, k)

    def _columns(self):
        columns = {"t": self.t}
        for k, id in enumerate(self.contact.tolist()):
            columns[_core.member_column("vx", id)] = self.vx[:, k]
            columns[_core.member_column("vy", id)] = self.vy[:, k]
        return columns

    def __repr__(self):
        return (f"Traces({self.t.size} times × {self.contact.size} contacts "
                f"{self.contact.tolist()}: vx, vy)")


@dataclass(frozen=True, repr=False)
class Events(_Table):
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


@dataclass(frozen=True, repr=False)
class Slips(_Table):
    """slips.csv, the event catalogue: one row per slip of a watched contact,
    from its slip event to its next stick event, in the order the slips end.
    A slip under way at t = 0 or still going at t_end has no row."""

    t_start: np.ndarray  # [s], the slip event
    t_end: np.ndarray  # [s], the stick event that ends it
    contact: np.ndarray  # contact id
    duration: np.ndarray  # [s], t_end - t_start
    slip: np.ndarray  # [m], |u(t_end) - u(t_start)|, u the contact's in-plane displacement
    peak_speed: np.ndarray  # [m/s], the largest |s| sampled in between (docs/USAGE.md)
    load_start: np.ndarray  # [N], |force of the block on the contact| at t_start
    load_end: np.ndarray  # [N], the same at t_end
    load_drop: np.ndarray  # [N], load_start - load_end
    F_f_start: np.ndarray  # [N], the block's friction force F_f at t_start
    F_f_end: np.ndarray  # [N], F_f at t_end
    F_f_drop: np.ndarray  # [N], F_f_start - F_f_end


@dataclass(frozen=True, repr=False)
class Contacts(_Table):
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
    def mu_error(self):
        """The standard error of μ from its own window (summary["mu_error"]:
        batch means over block cycles, or F_f's autocorrelation; not a spread
        over seeds); None if unfinished or not to be had."""
        return None if self.summary is None else self.summary.get("mu_error")

    @property
    def mu_trusted(self):
        """Whether μ is a friction coefficient: its window holds whole slip cycles
        or steady sliding (summary["regime"]); None if unfinished or not judged."""
        regime = None if self.summary is None else self.summary.get("regime")
        return None if regime is None else regime["mu_trusted"]

    def _shapes(self):
        """Its tables and their sizes, for the repr."""
        shapes = [f"friction ({self.friction.t.size} rows)", f"contacts ({self.contacts.id.size})"]
        if self.traces is not None:
            shapes.append(f"traces ({self.traces.t.size} × {self.traces.contact.size} contacts)")
        if self.events is not None:
            shapes.append(f"events ({self.events.t.size})")
        if self.slips is not None:
            shapes.append(f"slips ({self.slips.t_end.size})")
        shapes += [f"tables[{name!r}]" for name in self.tables]
        return shapes

    def __repr__(self):
        where = "no directory" if self.dir is None else str(self.dir)
        if self.summary is None:
            t = self.friction.t[-1] if self.friction.t.size else 0.0
            head = f"unfinished, reached t = {t:.6g} s"
        else:
            s = self.summary
            regime = s.get("regime")
            judged = "" if regime is None else (
                f" ({regime['kind']}, {'trusted' if regime['mu_trusted'] else 'not a friction coefficient'})")
            error = s.get("mu_error")
            pm = "" if error is None else f" ± {error:.2g}"
            auto = " (auto)" if s.get("average_from_auto") else ""
            head = (f"μ = {s['mu']:.6g}{pm}{judged} over [{s['average_from']:.6g}, {s['t_end']:.6g}] s{auto}; "
                    f"t_end {s['t_end']:.6g} s, method {s['solver']['method']}")
        return f"Run({where}\n  {head}\n  tables: {', '.join(self._shapes())})"

    def to_xarray(self):
        """friction (and traces, if traced) as an xarray Dataset: F_f and
        mu_inst over the coordinate t, vx and vy over (t, contact), with the
        traced contacts' ix, iy and v_star as coordinates of contact and each
        variable's unit in its "units" attribute. Traces on another time grid
        than friction's get their own coordinate, t_traces. Needs xarray."""
        import xarray

        f = self.friction
        variables = {
            "F_f": ("t", f.F_f, {"units": "N", "long_name": "friction force of the block"}),
            "mu_inst": ("t", f.mu_inst, {"units": "1", "long_name": "F_f / F_N"}),
        }
        coords = {"t": ("t", f.t, {"units": "s", "long_name": "time"})}
        if self.traces is not None:
            tr = self.traces
            t = "t"
            if not np.array_equal(tr.t, f.t):
                t = "t_traces"
                coords[t] = (t, tr.t, {"units": "s", "long_name": "time of the traces"})
            row = {id: k for k, id in enumerate(self.contacts.id.tolist())}
            at = np.array([row[id] for id in tr.contact.tolist()], dtype=np.int64)
            coords["contact"] = ("contact", tr.contact, {"long_name": "contact id"})
            coords["ix"] = ("contact", self.contacts.ix[at], {"long_name": "site x index"})
            coords["iy"] = ("contact", self.contacts.iy[at], {"long_name": "site y index"})
            coords["v_star"] = ("contact", self.contacts.v_star[at], {"units": "m/s"})
            variables["vx"] = ((t, "contact"), tr.vx, {"units": "m/s", "long_name": "contact x-velocity"})
            variables["vy"] = ((t, "contact"), tr.vy, {"units": "m/s", "long_name": "contact y-velocity"})
        attrs = {}
        if self.summary is not None:
            s = self.summary
            attrs = {"mu": s["mu"], "average_from": s["average_from"],
                     "t_end": s["t_end"], "F_N": s["F_N"], "theta": s["theta"]}
            # netCDF attributes hold no None: what is undefined is left out.
            if s.get("mu_error") is not None:
                attrs["mu_error"] = s["mu_error"]
            if s.get("regime") is not None:
                attrs["regime"] = s["regime"]["kind"]
                attrs["mu_trusted"] = int(s["regime"]["mu_trusted"])
        return xarray.Dataset(variables, coords=coords, attrs=attrs)


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
    running) as a Run. FileNotFoundError if there is no `dir`; OutputError if
    it holds no run (for a sweep's directory, saying to read its table with
    load_sweep)."""
    dir = Path(dir)
    if not dir.exists():
        raise FileNotFoundError(errno.ENOENT, "no such run directory", str(dir))
    if not _core.has_table(dir, "friction"):
        if (dir / _core.sweep_file).is_file():
            raise OutputError(f"{dir}: a sweep directory: read its {_core.sweep_file} with "
                              f"stickslip.load_sweep({str(dir)!r}), a point with "
                              f"stickslip.load() of its subdirectory")
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
        ids = [_core.column_member(name, "vx") for name in columns]
        ids = [i for i in ids if i is not None]
        t = columns["t"]

        def by_contact(axis):
            if not ids:
                return np.empty((t.size, 0))
            return np.stack([columns[_core.member_column(axis, i)] for i in ids], axis=1)

        traces = Traces(t=t, contact=np.array(ids, dtype=np.int64), vx=by_contact("vx"),
                        vy=by_contact("vy"))
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
        any_version=False, threads=None):
    """Integrates `case` (a Case, or a case file's path) and returns its Run.

    Without `out` the outputs go to a temporary directory that is removed
    once they are read (nothing is left on disk; [output] dir is not used).
    With `out`, its usual outputs are written there as `stickslip run --out`
    writes them, and stay; `overwrite` replaces an earlier run's results
    there, and `restart` continues the interrupted run there from its
    checkpoint (one written by another code version only with
    `any_version`; summary["provenance"]["segments"] lists each attempt's).
    `progress` shows the command line's progress line on stderr when stderr
    is a terminal, else (a notebook) a tqdm.auto bar of simulated time, if
    tqdm is installed.

    `case` may also be a dict, as Case.from_dict takes it. `threads` sets
    [solver] threads, as --threads does: the run's OpenMP threads, a count
    used as given, or 0: every core (or OMP_NUM_THREADS) for a lattice of
    1 000 nodes or more, one below (where threads cost more than they gain).

    The run releases the GIL, so runs in threads go side by side; give
    such runs threads=1 (the default, 0, gives each run of 1 000 nodes or
    more every core, and runs side by side would oversubscribe them). Ctrl-C
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
    if threads is not None:
        if isinstance(threads, bool) or not isinstance(threads, numbers.Integral) or threads < 0:
            raise ValueError(f"threads: expected a whole number >= 0, got {threads!r}")
        case = case.replace({"solver.threads": int(threads)})
    temporary = out is None
    if not temporary and str(out) == "":
        raise OutputError("out: an empty path; name a directory (or leave out `out` for none)")
    if restart and temporary:
        raise OutputError("restart=True needs `out`: the directory of the interrupted run")
    if any_version and not restart:
        raise OutputError("any_version=True applies to restart=True only")
    dir = Path(tempfile.mkdtemp(prefix="stickslip-run-")) if temporary else Path(out)
    try:
        bar = _progress_bar(case) if progress else None
        outcome = None
        try:
            outcome = _core.run(case._case, dir, overwrite, restart, any_version,
                                not progress or bar is not None, bar.update if bar else None)
        finally:
            if bar is not None:
                bar.close(json.loads(outcome) if isinstance(outcome, str) else None)
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


class _ProgressBar:
    """A tqdm.auto bar of simulated time (a notebook's widget, or text), which
    the run calls with (t, steps) at its first output time, then at most
    twice a second."""

    def __init__(self, tqdm, t_end):
        self._t_end = t_end
        self._bar = tqdm(total=t_end, unit="s", desc="t",
                         bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g} s [{elapsed}<{remaining}]{postfix}")

    def update(self, t, steps):
        self._bar.n = min(t, self._t_end)
        self._bar.set_postfix_str(f"{steps} steps", refresh=False)
        self._bar.refresh()

    def close(self, summary):
        """Closed at t_end with the run's steps if it finished (`summary`), else where it stopped."""
        if summary is not None:
            self.update(self._t_end, summary["solver_stats"]["steps"])
        self._bar.close()


def _progress_bar(case):
    """None where the command line's own progress line shows (stderr a
    terminal) or tqdm is missing; else a _ProgressBar."""
    try:
        if sys.stderr.isatty():
            return None
    except (AttributeError, ValueError):
        pass
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    return _ProgressBar(tqdm, case.to_dict()["run"]["t_end"])
