"""Rig-log datasets in the ``maglev-rig-log/1`` format (``shared/spec/RIG_LOG.md``).

A dataset is a folder with ``dataset.yaml`` (format, sample time, encoder
resolution, and the runs with their locked axes) and one CSV per run with the
columns ``t, g, d, i_q, i_d`` (SI units) plus any further columns. The plant
simulator writes datasets with :func:`write_dataset`; calibration and the gap
diagnosis read any dataset (rig or simulator) with :func:`read_dataset`.

The reader refuses bad data with a :class:`~maglev_ocp.errors.DataError` of one
line naming the file, the row and the column: YAML that does not parse or lacks
a field, a wrong ``format``, a missing run file, an empty file, a CSV with a
missing column, ragged rows, non-numeric or non-finite values, time that does
not strictly increase or is not evenly spaced at ``sample_time``, ``locked``
values other than ``[]``, ``[g]``, ``[d]``, and a locked axis that does not
read a constant.

Numbers are written with ``repr`` (the shortest string that reads back to the
same double), so a quantized position ``round(v / 1e-5) * 1e-5`` survives a
write and read bit for bit.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import os
import re
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field, field_validator

from . import constants as k
from .config import Strict, load_yaml, parse_model
from .errors import ConfigError, DataError
from .output import atomic_write_text, dump_yaml, plain_data

FORMAT = "maglev-rig-log/1"
REQUIRED_COLUMNS: tuple[str, ...] = ("t", "g", "d", "i_q", "i_d")
LOCK_CHOICES: tuple[tuple[str, ...], ...] = ((), ("g",), ("d",))
#: Allowed deviation of a time step from ``sample_time``, relative to it.
SAMPLE_TIME_TOLERANCE = 1e-2
#: Most columns a run's CSV may have (a runner's log has about 60).
MAX_COLUMNS: int = 4096
#: Longest cell (and column name) of a run's CSV, in characters (a float's ``repr`` needs at most 24).
MAX_CELL_CHARS: int = 1024
#: Physical range of each required column (SI units), from the stage's stops and its amplifier
#: (:mod:`maglev_ocp.constants`): the gap between 0 and twice its upper stop, d within twice its stops, a
#: commanded current within ten times the amplifier's limit. A gap or position logged in millimetres
#: (20 for 0.020 m) or a current of 1e308 A falls outside and is refused.
PHYSICAL_RANGES: dict[str, tuple[float, float, str]] = {
    "g": (0.0, 2.0 * k.g_stop[1], "m"),
    "d": (2.0 * k.d_stop[0], 2.0 * k.d_stop[1], "m"),
    "i_q": (-10.0 * k.i_amp_max, 10.0 * k.i_amp_max, "A"),
    "i_d": (-10.0 * k.i_amp_max, 10.0 * k.i_amp_max, "A"),
}
#: A plain decimal number (what RIG_LOG.md's numeric cells are): no ``_`` digit separators, no words.
_PLAIN_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")
_PLAIN_CHARS = frozenset("0123456789+-.eE")


def _fmt(v: Any) -> str:
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return str(v)


@dataclass
class RunLog:
    """One run of a dataset: named columns of equal length.

    Attributes
    ----------
    file : str
        CSV file name inside the dataset folder.
    columns : dict of str to ndarray
        Columns in file order; the required ones are ``t, g, d, i_q, i_d``
        (float), further ones are float where every value is a number, text otherwise.
    locked : tuple of str
        Axes held by a fixture: ``()``, ``("g",)`` or ``("d",)``.
    meta : dict
        Free-form metadata kept in ``dataset.yaml`` (e.g. the experiment).
    """

    file: str
    columns: dict[str, np.ndarray]
    locked: tuple[str, ...] = ()
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.locked = tuple(self.locked)
        if self.locked not in LOCK_CHOICES:
            raise ValueError(f"locked must be one of [], [g], [d], got {list(self.locked)}")
        cols = {}
        n = None
        for name, v in self.columns.items():
            a = np.asarray(v)
            if a.ndim != 1:
                raise ValueError(f"column {name!r} must be 1-D, got shape {a.shape}")
            if n is not None and len(a) != n:
                raise ValueError(f"column {name!r} has {len(a)} rows, expected {n}")
            n = len(a)
            cols[str(name)] = a
        self.columns = cols

    # ----------------------------------------------------------------- access
    @property
    def names(self) -> tuple[str, ...]:
        """Column names in file order."""
        return tuple(self.columns)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    def __len__(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    @property
    def t(self) -> np.ndarray:
        """Time [s]."""
        return self.columns["t"]

    @property
    def y(self) -> np.ndarray:
        """Encoder readings ``(g, d)`` [m], shape (N, 2)."""
        return np.column_stack([self.columns["g"], self.columns["d"]])

    @property
    def u(self) -> np.ndarray:
        """Commanded currents ``(i_q, i_d)`` [A], shape (N, 2)."""
        return np.column_stack([self.columns["i_q"], self.columns["i_d"]])

    @property
    def duration(self) -> float:
        """Time span of the run [s]."""
        t = self.t
        return float(t[-1] - t[0]) if len(t) else 0.0

    def with_columns(self, **cols: np.ndarray) -> RunLog:
        """Copy with columns added or replaced (appended after the existing ones)."""
        new = dict(self.columns)
        new.update({n: np.asarray(v) for n, v in cols.items()})
        return RunLog(self.file, new, self.locked, dict(self.meta))

    def renamed(self, file: str, locked: Iterable[str] | None = None, **meta: Any) -> RunLog:
        """Copy with a new file name (and optionally locked axes / extra metadata)."""
        return RunLog(file, dict(self.columns), tuple(self.locked if locked is None else locked), {**self.meta, **meta})

    # ----------------------------------------------------------------- output
    def to_csv_text(self) -> str:
        """The run as CSV text (header row, ``repr`` numbers so they read back bit for bit)."""
        missing = [c for c in REQUIRED_COLUMNS if c not in self.columns]
        if missing:
            raise ValueError(f"run {self.file!r} lacks the required columns {missing}")
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.names)
        cols = [c.tolist() for c in self.columns.values()]
        w.writerows([_fmt(v) for v in row] for row in zip(*cols, strict=True))
        return buf.getvalue()

    def save(self, csv_path: str | os.PathLike) -> Path:
        """Write the run as CSV atomically (temporary file, then rename)."""
        path = Path(csv_path)
        atomic_write_text(path, self.to_csv_text())
        return path

    def table(self, max_rows: int = 10) -> str:
        """Text view: header and the first / last rows."""
        names = self.names
        n = len(self)
        idx = list(range(n)) if n <= max_rows else [*range(max_rows // 2), -1, *range(n - max_rows // 2, n)]
        width = {c: max(len(c), 12) for c in names}
        lines = [f"{self.file}  ({n} rows, locked {list(self.locked)})", "  ".join(f"{c:>{width[c]}}" for c in names)]
        for i in idx:
            if i < 0:
                lines.append("  ".join(f"{'...':>{width[c]}}" for c in names))
                continue
            cells = []
            for c in names:
                v = self.columns[c][i]
                cells.append(f"{v:>{width[c]}.6g}" if isinstance(v, (float, np.floating)) else f"{v!s:>{width[c]}}")
            lines.append("  ".join(cells))
        return "\n".join(lines)

    def to_frame(self):  # pragma: no cover - needs the optional pandas
        """The run as a pandas DataFrame (needs pandas, from the ``campaign`` extra)."""
        try:
            import pandas as pd
        except ImportError as err:
            raise DataError("RunLog.to_frame needs pandas (pip install 'maglev-ocp[campaign]')") from err
        return pd.DataFrame(self.columns)


@dataclass
class Dataset:
    """A rig-log dataset: runs plus the sample time and encoder resolution.

    Attributes
    ----------
    folder : Path or None
        Where it was read from / written to.
    sample_time : float
        Control period [s]; rows are evenly spaced by it.
    encoder_resolution : float
        Encoder resolution [m].
    runs : list of RunLog
        The runs, in ``dataset.yaml`` order.
    meta : dict
        Free-form metadata (generator, seed, true parameters, ...).
    """

    sample_time: float
    encoder_resolution: float
    runs: list[RunLog]
    folder: Path | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    def __iter__(self) -> Iterator[RunLog]:
        return iter(self.runs)

    def __len__(self) -> int:
        return len(self.runs)

    def run(self, file: str) -> RunLog:
        """The run stored in ``file`` (KeyError naming the files otherwise)."""
        for r in self.runs:
            if r.file == file:
                return r
        raise KeyError(f"no run {file!r}; runs are {[r.file for r in self.runs]}")

    def save(self, folder: str | os.PathLike) -> Path:
        """Write the dataset to ``folder`` (see :func:`write_dataset`)."""
        return write_dataset(folder, self.runs, self.sample_time, self.encoder_resolution, meta=self.meta)

    def table(self) -> str:
        """Summary: one line per run (file, locked, rows, duration, ranges of g and d)."""
        head = (
            f"{'file':<32} {'locked':>6} {'rows':>7} {'T [s]':>8} {'g min..max [mm]':>17} "
            f"{'d min..max [mm]':>17} {'|i| max [A]':>11}"
        )
        lines = [
            f"dataset {self.folder or ''} ({FORMAT}, Ts = {self.sample_time:g} s, "
            f"encoder {self.encoder_resolution:g} m)",
            head,
            "-" * len(head),
        ]
        for r in self.runs:
            g, d = r["g"] * 1e3, r["d"] * 1e3
            imax = float(np.max(np.hypot(r["i_q"], r["i_d"])))
            lines.append(
                f"{r.file:<32} {','.join(r.locked) or '-':>6} {len(r):>7} {r.duration:>8.3f} "
                f"{g.min():>8.3f}..{g.max():<8.3f} {d.min():>8.3f}..{d.max():<8.3f} {imax:>11.3f}"
            )
        return "\n".join(lines)


# -------------------------------------------------------------------------- schema
class _RunEntry(Strict):
    file: str = Field(min_length=1)
    locked: list[str]
    meta: dict[str, Any] | None = None

    @field_validator("locked")
    @classmethod
    def _locked(cls, v: list[str]) -> list[str]:
        if tuple(v) not in LOCK_CHOICES:
            raise ValueError(f"must be [], [g] or [d], got {v}")
        return v

    @field_validator("file")
    @classmethod
    def _file(cls, v: str) -> str:
        p = Path(v)
        if p.is_absolute() or ".." in p.parts or len(p.parts) != 1:
            raise ValueError(f"must be a plain file name inside the dataset folder, got {v!r}")
        return v


class _DatasetFile(Strict):
    format: str
    sample_time: float = Field(gt=0, le=10.0)
    encoder_resolution: float = Field(gt=0, le=1e-2)
    runs: list[_RunEntry] = Field(min_length=1)
    description: str | None = None
    meta: dict[str, Any] | None = None


# ---------------------------------------------------------------------------- write
def write_dataset(
    folder: str | os.PathLike,
    runs: Iterable[RunLog],
    sample_time: float = k.Ts,
    encoder_resolution: float = k.encoder_resolution,
    meta: Mapping[str, Any] | None = None,
    description: str | None = None,
) -> Path:
    """Write runs as a ``maglev-rig-log/1`` dataset (CSV files, then ``dataset.yaml``, all atomic).

    Parameters
    ----------
    folder : path
        Dataset folder (created if needed; other files in it are left alone).
    runs : iterable of RunLog
        Runs with distinct file names.
    sample_time : float
        Control period [s].
    encoder_resolution : float
        Encoder resolution [m].
    meta : mapping, optional
        Free-form metadata stored under ``meta`` in ``dataset.yaml``.
    description : str, optional
        One line saying what the dataset is.

    Returns
    -------
    Path
        The dataset folder.
    """
    folder = Path(folder)
    runs = list(runs)
    if not runs:
        raise ValueError("a dataset needs at least one run")
    files = [r.file for r in runs]
    if len(set(files)) != len(files):
        raise ValueError(f"run file names must be distinct, got {files}")
    entries = []
    for r in runs:
        _RunEntry(file=r.file, locked=list(r.locked))  # same checks as the reader
        r.save(folder / r.file)
        entry: dict[str, Any] = {"file": r.file, "locked": list(r.locked)}
        if r.meta:
            entry["meta"] = plain_data(r.meta)
        entries.append(entry)
    doc: dict[str, Any] = {
        "format": FORMAT,
        "sample_time": float(sample_time),
        "encoder_resolution": float(encoder_resolution),
    }
    if description:
        doc["description"] = description
    if meta:
        doc["meta"] = plain_data(meta)
    doc["runs"] = entries
    dump_yaml(folder / "dataset.yaml", doc)
    return folder


def read_header(folder: str | os.PathLike) -> dict[str, Any]:
    """Read and validate a dataset's ``dataset.yaml`` only (not its CSV files).

    Returns
    -------
    dict
        The file's content as validated (``format``, ``sample_time``,
        ``encoder_resolution``, ``runs``, and ``description`` / ``meta`` if given).

    Raises
    ------
    DataError
        One line naming the file and the key.
    """
    return _read_doc(Path(folder) / "dataset.yaml").model_dump(exclude_none=True)


def merge_datasets(new_folder: str | os.PathLike, old_folder: str | os.PathLike) -> Path:
    """Append the runs of the dataset ``old_folder`` to the dataset in ``new_folder`` (a dataset never forgets runs).

    The old runs come first in ``dataset.yaml``, then the new ones; an old run
    whose file name a new run reuses is replaced by the new one (and its figure
    ``<stem>.png`` dropped). Other files of the old folder are copied. Where the
    old dataset-level ``meta`` differs from the new one, each kept old run
    carries it as ``meta.dataset_meta``, so it keeps its context.

    Raises
    ------
    DataError
        The two datasets differ in sample time or encoder resolution.
    """
    import shutil

    new_folder, old_folder = Path(new_folder), Path(old_folder)
    new, old = read_header(new_folder), read_header(old_folder)
    for key in ("sample_time", "encoder_resolution"):
        if new[key] != old[key]:
            raise DataError(
                f"{old_folder / 'dataset.yaml'}: {key} {old[key]:g} differs from the new runs' {new[key]:g}; "
                "use another dataset folder"
            )
    new_files = {e["file"] for e in new["runs"]}
    replaced_stems = {Path(f).stem for f in new_files}
    for p in sorted(old_folder.iterdir()):
        if p.name == "dataset.yaml" or p.name in new_files or (new_folder / p.name).exists():
            continue
        if p.suffix == ".png" and p.stem in replaced_stems:
            continue
        if p.is_file():
            shutil.copy2(p, new_folder / p.name)
    kept = []
    for e in old["runs"]:
        if e["file"] in new_files:
            continue
        if old.get("meta") and old.get("meta") != new.get("meta"):
            e = {**e, "meta": {**(e.get("meta") or {}), "dataset_meta": old["meta"]}}
        kept.append(e)
    doc = {k_: new[k_] for k_ in ("format", "sample_time", "encoder_resolution", "description", "meta") if k_ in new}
    doc["runs"] = kept + new["runs"]
    dump_yaml(new_folder / "dataset.yaml", plain_data(doc))
    return new_folder


# ----------------------------------------------------------------------------- read
def _read_doc(yml: Path) -> _DatasetFile:
    """Read and validate ``dataset.yaml`` (one-line DataError naming the file and key)."""
    try:
        raw = load_yaml(yml)
    except ConfigError as err:
        raise DataError(str(err)) from None
    if raw is None:
        raise DataError(f"{yml}: empty file")
    if not isinstance(raw, dict):
        raise DataError(f"{yml}: expected a mapping at the top level, got {type(raw).__name__}")
    if "format" in raw and raw["format"] != FORMAT:
        raise DataError(f"{yml}: format: expected {FORMAT!r}, got {raw['format']!r}")
    try:
        doc = parse_model(_DatasetFile, raw, str(yml))
    except ConfigError as err:
        raise DataError(str(err)) from None
    if not (math.isfinite(doc.sample_time) and math.isfinite(doc.encoder_resolution)):
        raise DataError(f"{yml}: sample_time and encoder_resolution must be finite")
    files = [e.file for e in doc.runs]
    for i, f in enumerate(files):
        if f in files[:i]:
            raise DataError(f"{yml}: runs.{i}.file: {f!r} is listed twice")
    return doc


def read_dataset(folder: str | os.PathLike) -> Dataset:
    """Read and validate a ``maglev-rig-log/1`` dataset.

    Parameters
    ----------
    folder : path
        The dataset folder (or its ``dataset.yaml``).

    Returns
    -------
    Dataset

    Raises
    ------
    DataError
        One line naming the file, row and column of the first problem found.
    """
    folder = Path(folder)
    if folder.is_file() and folder.name == "dataset.yaml":
        folder = folder.parent
    yml = folder / "dataset.yaml"
    if not folder.is_dir():
        raise DataError(f"{folder}: no such dataset folder")
    if not yml.is_file():
        raise DataError(f"{yml}: missing (a dataset folder needs dataset.yaml)")
    doc = _read_doc(yml)
    runs = []
    for i, e in enumerate(doc.runs):
        path = folder / e.file
        if not path.is_file():
            raise DataError(f"{yml}: runs.{i}.file: {e.file!r} does not exist in {folder}")
        runs.append(read_run(path, doc.sample_time, tuple(e.locked), meta=e.meta or {}))
    return Dataset(doc.sample_time, doc.encoder_resolution, runs, folder, dict(doc.meta or {}))


def read_run(
    path: str | os.PathLike, sample_time: float, locked: tuple[str, ...] = (), meta: dict[str, Any] | None = None
) -> RunLog:
    """Read and validate one run's CSV (see :func:`read_dataset` for what is refused).

    Limits: at most :data:`MAX_COLUMNS` columns and :data:`MAX_CELL_CHARS`
    characters per cell; a UTF-8 byte-order mark is ignored.
    """
    path = Path(path)
    header, body = _read_csv_rows(path)
    columns: dict[str, np.ndarray] = {}
    if body:
        cells = np.array(body, dtype=str)
        for j, name in enumerate(header):
            columns[name] = _column(path, name, np.char.strip(cells[:, j]))
    _check_time(path, columns["t"], sample_time)
    _check_locked(path, columns, locked)
    return RunLog(path.name, columns, locked, dict(meta or {}))


def _read_csv_rows(path: Path) -> tuple[list[str], list[list[str]]]:
    """Header and data rows of a run's CSV; checks the header, the row widths and the cell sizes."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise DataError(f"{path}: not a text file (cannot decode as UTF-8)") from None
    except OSError as err:
        raise DataError(f"{path}: cannot read: {err.strerror or err}") from None
    if not text.strip():
        raise DataError(f"{path}: empty file")
    reader = csv.reader(io.StringIO(text))
    lines: list[list[str]] = []
    try:
        with wide_csv_fields():
            for row in reader:
                lines.append(row)
                if len(lines) == 1:
                    _check_header(path, row)
    except csv.Error as err:
        r = reader.line_num - 1
        where = "header (line 1)" if r <= 0 else f"row {r} (line {r + 1})"
        raise DataError(f"{path}: {where}: not valid CSV: {err}") from None
    # drop trailing blank lines only; a blank line inside the data is an error
    while lines and not any(c.strip() for c in lines[-1]):
        lines.pop()
    header = [c.strip() for c in lines[0]]
    body = lines[1:]
    if len(body) < 2:
        raise DataError(f"{path}: needs at least 2 data rows, found {len(body)}")
    n = len(header)
    for r, row in enumerate(body, start=1):
        if len(row) != n:
            raise DataError(f"{path}: row {r} (line {r + 1}): {len(row)} fields, but the header has {n} columns")
        for j, cell in enumerate(row):
            if len(cell) > MAX_CELL_CHARS:
                raise DataError(
                    f"{path}: row {r} (line {r + 1}), column {header[j]!r}: cell of {len(cell)} characters "
                    f"(the limit is {MAX_CELL_CHARS})"
                )
    return header, body


@contextlib.contextmanager
def wide_csv_fields(limit: int = 1 << 26) -> Iterator[None]:
    """Let the ``csv`` module read fields up to ``limit`` characters inside the block.

    The module's default (131072) would stop a huge cell with an error that
    names only the line; with the limit raised, the reader's own cell check
    (:data:`MAX_CELL_CHARS`) names the row and the column.
    """
    previous = csv.field_size_limit(limit)
    try:
        yield
    finally:
        csv.field_size_limit(previous)


def _check_header(path: Path, row: list[str]) -> None:
    """Column count, names (non-empty, distinct, not too long) and the required columns (linear time)."""
    if len(row) > MAX_COLUMNS:
        raise DataError(f"{path}: header (line 1): {len(row)} columns (the limit is {MAX_COLUMNS})")
    seen: set[str] = set()
    for j, raw in enumerate(row):
        name = raw.strip()
        if not name:
            raise DataError(f"{path}: header (line 1): column {j + 1} has no name")
        if len(name) > MAX_CELL_CHARS:
            raise DataError(
                f"{path}: header (line 1): column {j + 1}: name of {len(name)} characters (limit {MAX_CELL_CHARS})"
            )
        if name in seen:
            raise DataError(f"{path}: header (line 1): column {name!r} appears twice")
        seen.add(name)
    missing = [c for c in REQUIRED_COLUMNS if c not in seen]
    if missing:
        names = ", ".join(c.strip() for c in row[:20]) + (", ..." if len(row) > 20 else "")
        raise DataError(f"{path}: header (line 1): missing column {missing[0]!r} (header has {names})")


def _column(path: Path, name: str, raw: np.ndarray) -> np.ndarray:
    """One column as floats (required columns must be finite numbers), or as text for a free extra column."""
    required = name in REQUIRED_COLUMNS
    try:
        vals = raw.astype(float)
    except ValueError:
        if required:
            r = _first_bad(raw)
            raise DataError(
                f"{path}: row {r + 1} (line {r + 2}), column {name!r}: not a number: {str(raw[r])!r}"
            ) from None
        return raw  # free-text extra column (flags, notes), kept as text
    if required:
        bad = np.flatnonzero(~np.isfinite(vals))
        if bad.size:
            r = int(bad[0])
            raise DataError(f"{path}: row {r + 1} (line {r + 2}), column {name!r}: non-finite value {raw[r]!r}")
        _check_plain(path, name, raw)
        _check_range(path, name, vals)
    return vals


def is_plain_number(cell: str) -> bool:
    """``cell`` (stripped) is a plain decimal number: ``-0.004``, ``4e-3``; not ``0.00_4``, ``٣`` or ``inf``."""
    return _PLAIN_NUMBER.fullmatch(cell.strip()) is not None


def _check_plain(path: Path, name: str, raw: np.ndarray) -> None:
    """Every cell a plain decimal number (Python's float() also takes ``0.00_4`` and other digit forms)."""
    if set("".join(raw.tolist())) <= _PLAIN_CHARS and not any("_" in c for c in raw.tolist()):
        return  # fast path: only digits, signs, points and exponents (their arrangement float() has checked)
    for r, cell in enumerate(raw.tolist()):
        if not is_plain_number(cell):
            raise DataError(
                f"{path}: row {r + 1} (line {r + 2}), column {name!r}: {cell!r} is not a plain number "
                "(digits, '.', an optional exponent; no '_' or other characters)"
            )


def _check_range(path: Path, name: str, vals: np.ndarray) -> None:
    """Values within :data:`PHYSICAL_RANGES` (one line naming the row, the column, the range and the units)."""
    if name not in PHYSICAL_RANGES:
        return
    lo, hi, unit = PHYSICAL_RANGES[name]
    bad = np.flatnonzero((vals < lo) | (vals > hi))
    if bad.size:
        r = int(bad[0])
        hint = " (SI units: metres, not millimetres)" if unit == "m" else ""
        raise DataError(
            f"{path}: row {r + 1} (line {r + 2}), column {name!r}: {vals[r]:g} {unit} is outside the physical "
            f"range {lo:g}..{hi:g} {unit}{hint}"
        )


def _check_time(path: Path, t: np.ndarray, sample_time: float) -> None:
    """Time strictly increases, evenly spaced at ``sample_time`` (within :data:`SAMPLE_TIME_TOLERANCE`)."""
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        r = int(bad[0]) + 1
        raise DataError(
            f"{path}: row {r + 1} (line {r + 2}), column 't': time does not increase ({t[r - 1]!r} then {t[r]!r})"
        )
    bad = np.flatnonzero(np.abs(dt - sample_time) > SAMPLE_TIME_TOLERANCE * sample_time)
    if bad.size:
        r = int(bad[0]) + 1
        raise DataError(
            f"{path}: row {r + 1} (line {r + 2}), column 't': time step {dt[r - 1]:.6g} s differs "
            f"from sample_time {sample_time:g} s"
        )


def _check_locked(path: Path, columns: dict[str, np.ndarray], locked: tuple[str, ...]) -> None:
    """A locked axis reads a constant."""
    for ax in locked:
        v = columns[ax]
        bad = np.flatnonzero(v != v[0])
        if bad.size:
            r = int(bad[0])
            raise DataError(
                f"{path}: row {r + 1} (line {r + 2}), column {ax!r}: axis {ax} is locked but its "
                f"reading changes ({v[0]!r} then {v[r]!r})"
            )


def _first_bad(raw: np.ndarray) -> int:
    for i, s in enumerate(raw):
        try:
            float(s)
        except ValueError:
            return i
    return 0  # pragma: no cover


__all__ = [
    "FORMAT",
    "MAX_CELL_CHARS",
    "MAX_COLUMNS",
    "PHYSICAL_RANGES",
    "REQUIRED_COLUMNS",
    "Dataset",
    "RunLog",
    "is_plain_number",
    "merge_datasets",
    "read_dataset",
    "read_header",
    "read_run",
    "write_dataset",
]
