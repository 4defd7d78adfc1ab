"""Cases: read from TOML or from a dict, changed like --set, written as TOML."""

import errno
import json
import math
import numbers
import re
from pathlib import Path

from . import _core
from ._core import CaseError

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def toml_value(value, key):
    """`value` as TOML text (what --set takes); CaseError naming `key` if it has no TOML form."""
    if hasattr(value, "dtype") and getattr(value, "ndim", None) == 0:  # a numpy scalar
        if value.dtype.kind == "f" and value.dtype.itemsize < 8:
            return toml_value(float(str(value)), key)  # float32(3e-4) means 3e-4, not 3.0000001e-4
        value = value.item()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        x = float(value)
        if math.isnan(x):
            return "nan"
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return repr(x)  # the shortest text that reads back as x
    if isinstance(value, (str, Path)):
        return json.dumps(str(value))  # a TOML basic string
    if isinstance(value, dict):
        items = []
        for k, v in value.items():
            name = str(k) if _BARE_KEY.match(str(k)) else json.dumps(str(k))
            items.append(f"{name} = {toml_value(v, f'{key}.{k}')}")
        return "{" + ", ".join(items) + "}"
    if isinstance(value, (list, tuple)) or hasattr(value, "tolist"):  # numpy arrays too
        items = value.tolist() if hasattr(value, "tolist") else list(value)
        return "[" + ", ".join(toml_value(v, key) for v in items) + "]"
    raise CaseError(f"{key}: {type(value).__name__} is not a case value ({value!r})")


def _override(dotted, value):
    """"section.key=value", the key checked first (so that no text of it can change the value)."""
    problem = _core.case_key_problem(dotted)
    if problem:
        raise CaseError(f"{dotted}: {problem}")
    return f"{dotted}={toml_value(value, dotted)}"


def _overrides(changes):
    """{"section.key": value} or {"section": {"key": value}} as "section.key=value" strings.
    A key given twice in one dict (as "lattice.nx" and in {"lattice": {"nx": ...}}) is
    refused, as a TOML file refuses a duplicate key: which one was meant is not known."""
    if not isinstance(changes, dict):
        raise CaseError(f"expected a dict of case keys, got {type(changes).__name__}")
    overrides, given = [], {}

    def add(dotted, value, spelling):
        if dotted in given:
            raise CaseError(f"{dotted}: given twice, as {given[dotted]} and as {spelling}; "
                            "give it once")
        given[dotted] = spelling
        overrides.append(_override(dotted, value))

    for name, value in changes.items():
        name = str(name)
        if "." in name:
            add(name, value, repr(name))
        elif isinstance(value, dict):
            for key, v in value.items():
                add(f"{name}.{key}", v, f"{{{name!r}: {{{str(key)!r}: ...}}}}")
        elif not _BARE_KEY.match(name):
            raise CaseError(f"{name!r}: expected a section or section.key")
        else:
            problem = _core.case_key_problem(name + ".x")
            if problem.startswith("unknown key"):  # `name` is a section
                problem = f"expected a dict of the section's keys, got {type(value).__name__}"
            raise CaseError(f"{name}: {problem}")
    return overrides


class Case:
    """A validated case: the same sections, keys, defaults and checks as a case file.

    Made with Case.from_toml(path) or Case.from_dict({...}); case.replace({...})
    gives a changed copy (as --set does); case.to_toml() and case.to_dict()
    give it back with every value resolved. A bad key or value raises CaseError
    with the key and why in its message.
    """

    def __init__(self, text, source, overrides, validated):
        self._text = text  # the TOML text the case starts from ("" for a dict; None: reread the file)
        self._source = source
        self._overrides = list(overrides)
        self._case = validated  # _core.Case

    @classmethod
    def from_toml(cls, path):
        """The case file at `path`, as `stickslip run` reads it;
        FileNotFoundError if there is none."""
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(errno.ENOENT, "no such case file", str(path))
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):  # the C++ reader says why, in the command line's words
            return cls(None, path, [], _core.read_case(path, []))
        return cls(text, path, [], _core.parse_case(text, path, []))

    @classmethod
    def from_dict(cls, sections):
        """A case from {"section": {"key": value}} and/or {"section.key": value};
        what it leaves out has its default (MODEL.md §10)."""
        overrides = _overrides(sections)
        return cls("", Path("<dict>"), overrides, _core.parse_case("", Path("<dict>"), overrides))

    def replace(self, changes=None, /, **dotted):
        """A copy with `changes` ({"drive.velocity": 3e-4}, or by section) and/or
        keyword changes (replace(**{"run.t_end": 1e-2}), replace(run={"t_end": 1e-2}))
        applied, validated again: the same as --set on the command line."""
        if changes is not None and not isinstance(changes, dict):
            _overrides(changes)  # refused, naming its type
        both = dict(changes or {})
        for name, value in dotted.items():
            if name in both:
                raise CaseError(f"{name}: given twice, in the dict and as a keyword; give it once")
            both[name] = value
        overrides = self._overrides + _overrides(both)
        if self._text is None:
            validated = _core.read_case(self._source, overrides)
        else:
            validated = _core.parse_case(self._text, self._source, overrides)
        return Case(self._text, self._source, overrides, validated)

    def __getitem__(self, section):
        """A section's resolved values, read-only: case["run"]["average_from"]."""
        d = self.to_dict()
        if section not in d:
            raise KeyError(f"{section!r}: no such section (sections: {', '.join(d)})")
        return _Section(section, d[section])

    def __getattr__(self, name):
        """A section as an attribute: case.run.average_from (read-only; replace() changes)."""
        if name.startswith("_"):
            raise AttributeError(name)
        d = self.to_dict()
        if name not in d:
            raise AttributeError(f"Case has no attribute or section {name!r} "
                                 f"(sections: {', '.join(d)})")
        return _Section(name, d[name])

    @property
    def source(self):
        """The case file it was read from (Path("<dict>") for a dict)."""
        return self._source

    @property
    def coverage(self):
        """θ as placed: an explicit contacts list's (contacts/(nx*ny)), else
        interface.coverage rounded to a whole number of contacts."""
        return self._case.coverage

    def to_dict(self):
        """Every section and key, defaults filled in (summary.json's "case" without "source")."""
        resolved = json.loads(self._case.to_json())
        resolved.pop("source", None)
        return resolved

    def to_toml(self):
        """The case as a TOML case file, every value resolved: reading it back gives this case."""
        return _core.to_toml(self._case)

    def __reduce__(self):  # pickled as its recipe, validated again when unpickled
        return (_restore, (self._text, str(self._source), self._overrides))

    def __eq__(self, other):
        return isinstance(other, Case) and self.to_dict() == other.to_dict()

    def __repr__(self):
        d = self.to_dict()
        lattice, solver = d["lattice"], d["solver"]
        listed = d["interface"].get("contacts") or []
        contacts = f"{len(listed)} contacts listed, " if listed else ""
        return (
            f"Case({str(self._source)!r}: {lattice['nx']}x{lattice['ny']}x{lattice['nz']}, "
            f"{contacts}coverage {self.coverage:.4g}, v {d['drive']['velocity']} m/s, "
            f"t_end {d['run']['t_end']} s, {solver['method']} rtol {solver['rtol']})"
        )


class _Section:
    """One section of a Case, read-only, by key or attribute: s["t_end"], s.t_end."""

    def __init__(self, name, values):
        self._name, self._values = name, values

    def __getitem__(self, key):
        if key not in self._values:
            raise KeyError(f"{self._name}.{key}: no such key (keys: {', '.join(self._values)})")
        return self._values[key]

    def __getattr__(self, key):
        if key.startswith("_"):
            raise AttributeError(key)
        try:
            return self[key]
        except KeyError as e:
            raise AttributeError(str(e)) from None

    def __setattr__(self, key, value):
        if key.startswith("_"):
            return object.__setattr__(self, key, value)
        raise AttributeError(f"{self._name}.{key}: a Case is read-only; "
                             f"use case.replace({{'{self._name}.{key}': ...}})")

    __setitem__ = __setattr__

    def __iter__(self):
        return iter(self._values)

    def __len__(self):
        return len(self._values)

    def keys(self):
        return self._values.keys()

    def items(self):
        return self._values.items()

    def __eq__(self, other):
        return dict(self._values) == (dict(other._values) if isinstance(other, _Section) else other)

    def __repr__(self):
        return f"{self._name}: {self._values!r}"


def _restore(text, source, overrides):
    source = Path(source)
    if text is None:
        return Case(None, source, overrides, _core.read_case(source, overrides))
    return Case(text, source, overrides, _core.parse_case(text, source, overrides))
