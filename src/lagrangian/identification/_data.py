"""Measurements: the data a fit compares the model with, one experiment per table.

A table has a time column (named ``t`` or ``time``, else the first) and measured columns named as
the model's coordinates (``theta``), velocities (``theta_dot``), inputs (``F``: used as the input
signal, interpolated, not fitted), named outputs, or components of a point's position (``bob.x``).
Every value is checked once, up front: a bad cell, a NaN row, an unsorted or repeated time, a table
too large or too small is one error naming the file, the row and the column, and the fix. Nothing
read from a table is evaluated: a header is a name, matched as text against the model's names.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .._limits import MAX_ROWS
from .._util import did_you_mean, read_only
from ..errors import ModelError

__all__ = ["Measurements", "measurements", "read_measurements"]

#: The fewest samples of an experiment a fit accepts.
MIN_SAMPLES = 3
#: The most measured columns of one table.
MAX_COLUMNS = 1000
#: The longest header name a table may have (a column is a model's name: short).
MAX_NAME = 200


@dataclass(frozen=True, eq=False)
class Measurements:
    """One experiment: sample times and measured columns.

    Attributes
    ----------
    t : ndarray, shape (N,)
        The sample times, strictly increasing.
    columns : dict of str to ndarray, each shape (N,)
        The measured values by column name (a coordinate, velocity, input, output or "<point>.x").
    source : str
        Where the table came from (a file's path, or "experiment 1" for arrays).
    """

    t: np.ndarray
    columns: dict
    source: str = "data"

    def __post_init__(self):
        object.__setattr__(self, "t", read_only(self.t, float))
        object.__setattr__(self, "columns", {k: read_only(v, float) for k, v in self.columns.items()})

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.columns)

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        return (f"Measurements({self.source!r}, {len(self.t)} samples on [{self.t[0]:g}, {self.t[-1]:g}], "
                f"columns {', '.join(self.columns)})")


def _clean_name(name, where: str) -> str:
    if not isinstance(name, str):
        raise ModelError(f"{where}: a column name must be text, not {type(name).__name__}; name the columns after "
                         "the model's coordinates, velocities, inputs, outputs or points (bob.x)")
    name = name.strip()
    if not name or len(name) > MAX_NAME or any(not c.isprintable() for c in name):
        shown = repr(name[:40] + ("..." if len(name) > 40 else ""))
        raise ModelError(f"{where}: the column name {shown} is empty, longer than {MAX_NAME} characters or holds "
                         "control characters; name the columns after the model's coordinates, velocities, inputs, "
                         "outputs or points (bob.x)")
    return name


def _check_times(t: np.ndarray, where: str, row_of=lambda i: f"sample {i}") -> None:
    if t.size < MIN_SAMPLES:
        raise ModelError(f"{where}: {t.size} sample(s); a fit needs at least {MIN_SAMPLES} per experiment (more "
                         "samples than unknowns to determine anything); give more rows")
    if t.size > MAX_ROWS.value:
        raise ModelError(f"{where}: {t.size:,} samples; {MAX_ROWS.how_to_raise()}")
    steps = np.diff(t)
    bad = np.flatnonzero(~(steps > 0))
    if bad.size:
        k = int(bad[0]) + 1
        kind = "repeats" if t[k] == t[k - 1] else "is earlier than"
        raise ModelError(f"{where}: {row_of(k)}, time {t[k]:g} {kind} the time {t[k - 1]:g} before it; times "
                         "must increase strictly (sort the rows by time and remove repeated times)")


def read_measurements(path) -> Measurements:
    """The measurements of a CSV file: a header row, then rows of numbers.

    The time column is the one named ``t`` or ``time`` (else the first); every other column is a
    measured quantity. A cell that is not a finite number (text, empty, NaN, inf) is an error that
    names the file, the row and the column.

    Raises
    ------
    ModelError
        An unreadable file, a bad header, a bad cell, unsorted or repeated times, too few or too many rows.
    """
    import csv

    path = os.fspath(path)
    try:
        size = os.path.getsize(path)
        with open(path, newline="", encoding="utf-8-sig") as fh:
            # about 4 characters a cell at the least: a bound on the file before it is read
            if size > 64 * MAX_ROWS.value * 4:
                raise ModelError(f"{path}: the file has {size:,} bytes, more than a table of {MAX_ROWS.value:,} rows "
                                 f"could need; {MAX_ROWS.how_to_raise()}")
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise ModelError(f"cannot read the measurements file {path}: {exc.strerror or exc}; check the path") from None
    except UnicodeDecodeError:
        raise ModelError(f"{path}: not a text CSV file (not UTF-8); save the measurements as CSV text") from None
    except csv.Error as exc:
        raise ModelError(f"{path}: not a CSV table ({exc}); save the measurements as CSV text, a header row and "
                         "rows of numbers") from None
    numbered = [(r, row) for r, row in enumerate(rows, start=1) if any(c.strip() for c in row)]
    if not numbered:
        raise ModelError(f"{path}: the file is empty; expected a header row (t,theta,...) and rows of numbers")
    head_row, header = numbered[0]
    header = [_clean_name(c, f"{path}: row {head_row}, column {k + 1}") for k, c in enumerate(header)]
    if len(header) > MAX_COLUMNS + 1:
        raise ModelError(f"{path}: {len(header)} columns; a fit reads at most {MAX_COLUMNS} measured columns")
    seen = set()
    for h in header:
        if h in seen:
            raise ModelError(f"{path}: the column '{h}' appears twice in the header; give each column once")
        seen.add(h)
    lowered = [h.lower() for h in header]
    ti = lowered.index("t") if "t" in lowered else (lowered.index("time") if "time" in lowered else 0)
    if len(header) < 2:
        raise ModelError(f"{path}: only the time column '{header[ti]}'; add measured columns (a coordinate, velocity, "
                         "input, output or point such as bob.x)")
    data = numbered[1:]
    if len(data) > MAX_ROWS.value:
        raise ModelError(f"{path}: {len(data):,} data rows; {MAX_ROWS.how_to_raise()}")
    values = np.empty((len(data), len(header)))
    for i, (r, row) in enumerate(data):
        if len(row) != len(header):
            raise ModelError(f"{path}: row {r} has {len(row)} cells but the header has {len(header)}; give every row "
                             "one cell per column")
        for k, cell in enumerate(row):
            text = cell.strip()
            try:
                x = float(text) if len(text) < 64 else math.nan
            except ValueError:
                x = math.nan
            if not math.isfinite(x):
                shown = repr(text[:30]) if text else "empty"
                raise ModelError(f"{path}: row {r}, column '{header[k]}': {shown} is not a finite number; every cell "
                                 "must be a number (remove the row, or fill the missing value)")
            values[i, k] = x
    rows_of = [r for r, _ in data]
    t = values[:, ti]
    _check_times(t, path, lambda i: f"row {rows_of[i]}")
    columns = {h: values[:, k] for k, h in enumerate(header) if k != ti}
    return Measurements(t, columns, path)


def _from_mapping(data: Mapping, source: str) -> Measurements:
    names = list(data)
    for k in names:
        _clean_name(k, source)
    tkey = next((k for k in names if isinstance(k, str) and k.strip().lower() in ("t", "time")), None)
    if tkey is None:
        raise ModelError(f"{source}: no time column; give the sample times under 't' (e.g. "
                         "{'t': times, 'theta': angles})")
    arrays = {}
    for k in names:
        try:
            a = np.asarray(data[k], dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{source}: column '{k}' is not an array of numbers") from None
        if a.ndim != 1:
            raise ModelError(f"{source}: column '{k}' has shape {a.shape}; give one value per sample (shape (N,))")
        arrays[k.strip()] = a
    t = arrays.pop(tkey.strip())
    for k, a in arrays.items():
        if a.size != t.size:
            raise ModelError(f"{source}: column '{k}' has {a.size} values but there are {t.size} times; give one value "
                             "per time")
    if not arrays:
        raise ModelError(f"{source}: only the time column; add measured columns (a coordinate, velocity, input, "
                         "output or point such as bob.x)")
    for k, a in (("t", t), *arrays.items()):
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise ModelError(f"{source}: sample {bad[0]}, column '{k}': {a[bad[0]]} is not a finite number; remove "
                             "the sample or fill the missing value")
    _check_times(t, source)
    return Measurements(t, arrays, source)


def measurements(data) -> list[Measurements]:
    """The experiments of `data`: a CSV path, a mapping of column name to array (with ``t``), a
    :class:`Measurements`, or a list of those (one experiment each)."""
    if isinstance(data, (str, os.PathLike, Mapping, Measurements)):
        data = [data]
    if not isinstance(data, Sequence) or isinstance(data, (bytes, bytearray)):
        raise ModelError(f"data: expected a CSV path, a mapping of column name to array (with 't'), or a list of "
                         f"those (one per experiment), not {type(data).__name__}")
    if not data:
        raise ModelError("data: no experiment given; pass a CSV path or a mapping of column name to array")
    out = []
    for i, d in enumerate(data, start=1):
        if isinstance(d, Measurements):
            out.append(d)
        elif isinstance(d, (str, os.PathLike)):
            out.append(read_measurements(d))
        elif isinstance(d, Mapping):
            out.append(_from_mapping(d, f"experiment {i}"))
        else:
            raise ModelError(f"data: experiment {i} is a {type(d).__name__}; give a CSV path or a mapping of column "
                             "name to array (with 't')")
    return out


def unknown_column(name: str, source: str, known: Sequence[str]) -> ModelError:
    """The error for a column that names nothing of the model."""
    return ModelError(f"{source}: the column '{name}' is not a coordinate, velocity, input, output or point of the "
                      f"model{did_you_mean(name, known)}; name the columns after "
                      f"{', '.join(list(known)[:12])}{', ...' if len(known) > 12 else ''} (or a point's "
                      "position such as bob.x), or remove it")
