"""What every plot script does with its command line: `--help` (or `-h`)
prints its usage on stdout (exit 0); a wrong number of arguments prints it on
stderr (exit 2); a directory that does not exist is an error naming it
(exit 2), before anything is read or drawn."""
import sys
from pathlib import Path


def arguments(usage: str, least: int, most=None) -> list:
    """The script's arguments, between `least` and `most` (None: no limit) of them."""
    args = sys.argv[1:]
    if "-h" in args or "--help" in args:
        print(usage.strip())
        raise SystemExit(0)
    if len(args) < least or (most is not None and len(args) > most):
        print(usage.strip(), file=sys.stderr)
        raise SystemExit(2)
    return args


def directories(paths) -> list:
    """`paths` as Paths, each an existing directory, else an error (exit 2)."""
    for p in paths:
        if not Path(p).is_dir():
            print(f"error: {p}: not found (no such directory)", file=sys.stderr)
            raise SystemExit(2)
    return [Path(p) for p in paths]
