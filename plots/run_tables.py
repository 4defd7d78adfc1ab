"""A run's tables, from its CSV files or from its run.h5 ([output] format = "hdf5").

read_table(out, "traces") gives the table's columns by their CSV names, as
numpy arrays, in either format: a 2-D HDF5 dataset such as traces/vx
[time x contact] becomes the columns vx_<id> of the contact ids in
traces/contact, and the events' kind reads as its text ("slip", "stick").
"""
import csv
from pathlib import Path

import numpy as np


def where(out: Path, name: str) -> str:
    """Where table `name` of the run in `out` is (for messages)."""
    h5 = Path(out) / "run.h5"
    return f"{h5}:/{name}" if h5.is_file() else str(Path(out) / f"{name}.csv")


def read_table(out: Path, name: str):
    """Table `name` of the run in `out` as {column: numpy array}, or None if the run has none."""
    out = Path(out)
    if (out / "run.h5").is_file():
        return _read_hdf5(out / "run.h5", name)
    path = out / f"{name}.csv"
    if not path.is_file():
        return None
    with path.open() as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = list(reader)
    columns = {}
    for i, column in enumerate(header):
        texts = [row[i] for row in rows]
        try:
            columns[column] = np.array([float(x) for x in texts])
        except ValueError:  # a label column (events' kind)
            columns[column] = np.array(texts)
    return columns


def _read_hdf5(path: Path, name: str):
    import h5py  # only runs in format "hdf5" need it

    # Without the file lock: a run in progress holds it (what it flushed is readable).
    with h5py.File(path, "r", locking=False) as f:
        if name not in f:
            return None
        group = f[name]
        members = {group[d].attrs["members"] for d in group if "members" in group[d].attrs}
        columns = {}
        for dataset in group:  # in the order the run made them
            if dataset in members:
                continue
            data = group[dataset]
            values = data[()]
            labels = h5py.check_enum_dtype(data.dtype)
            if labels is not None:
                text = {code: label for label, code in labels.items()}
                values = np.array([text[int(v)] for v in values])
            if values.ndim == 2:
                if "members" not in data.attrs:
                    raise SystemExit(f"error: {path}:/{name}/{dataset}: 2-D without a members attribute")
                ids = group[data.attrs["members"]][()]
                for k, member in enumerate(ids):
                    columns[f"{dataset}_{member}"] = values[:, k]
            else:
                columns[dataset] = values
        return columns
