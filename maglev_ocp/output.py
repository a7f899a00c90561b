"""Writing results: files and folders whole or not at all, and checks of output paths before any work.

Every result the suite writes goes through here: a file is written to a
temporary sibling and renamed over the target (never a truncated file), a
results folder is built beside the old one and swapped in whole
(:func:`replace_dir`), and an output path is checked before a long
computation starts (:func:`check_output_dir`, :func:`check_output_file`).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .errors import ConfigError
from .interrupts import sigint_deferred


def _umask_mode() -> int:
    """File mode an ordinary ``open(..., "w")`` would give (``mkstemp`` makes files 0600)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def _atomic_write(path: str | os.PathLike, mode: str, suffix: str, write: Any) -> None:
    """Write through ``write(file_handle)`` into a temporary sibling of ``path``, then rename it over ``path``.

    A crash or an error part-way never leaves a truncated file, and what was
    there before stays until the new content is complete.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    try:
        with os.fdopen(fd, mode) as fh:
            write(fh)
        os.chmod(tmp, _umask_mode())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def make_dir(path: str | os.PathLike) -> Path:
    """The folder ``path`` as a :class:`~pathlib.Path`, created with its parents if missing."""
    out = Path(path)
    out.mkdir(parents=True, exist_ok=True)
    return out


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` via a temporary file and rename (never a truncated file)."""
    _atomic_write(path, "w", ".tmp", lambda fh: fh.write(text))


def plain_data(v: Any) -> Any:
    """Copy of ``v`` safe for a YAML dump.

    Mappings become dicts with string keys, tuples and arrays lists, numpy scalars Python numbers.
    """
    if isinstance(v, Mapping):
        return {str(a): plain_data(b) for a, b in v.items()}
    if isinstance(v, (list, tuple)):
        return [plain_data(x) for x in v]
    if isinstance(v, np.ndarray):
        return [plain_data(x) for x in v.tolist()]
    if isinstance(v, np.generic):
        return v.item()
    return v


def dump_yaml(path: str | os.PathLike, data: Any) -> None:
    """Atomically write ``data`` as YAML."""
    atomic_write_text(path, yaml.safe_dump(data, sort_keys=False))


def atomic_write_bytes(path: str | os.PathLike, fig_or_bytes: Any, **savefig_kw: Any) -> None:
    """Atomically write bytes, or a matplotlib figure (PNG by the path's suffix)."""
    path = Path(path)

    def write(fh) -> None:
        if isinstance(fig_or_bytes, (bytes, bytearray)):
            fh.write(fig_or_bytes)
        else:
            fmt = path.suffix.lstrip(".") or "png"
            fig_or_bytes.savefig(fh, format=fmt, dpi=savefig_kw.pop("dpi", 110), **savefig_kw)

    _atomic_write(path, "wb", path.suffix or ".tmp", write)


def _probe_write(folder: Path, what: str) -> None:
    """Create and remove a temporary file in ``folder``; a one-line ConfigError if that fails."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".maglev-probe-", dir=folder)
        os.close(fd)
        os.unlink(tmp)
    except OSError as err:
        raise ConfigError(f"{what}: cannot write in {folder}: {err.strerror or err}") from None


# --------------------------------------------------------------------------- output paths
def _nearest_existing(path: Path) -> Path:
    """``path`` or its closest ancestor that exists (``path`` is absolute)."""
    cur = path
    while not cur.exists() and cur != cur.parent:
        cur = cur.parent
    return cur


def _check_ancestors(path: Path, what: str, label: str) -> None:
    """Every existing ancestor of ``path`` must be a folder we can create ``path`` in."""
    base = _nearest_existing(path.parent)
    if not base.is_dir():
        raise ConfigError(f"{what}: {label}: {base} is a file, not a folder")
    _probe_write(base, f"{what}: {label}")


def check_output_dir(
    path: str | os.PathLike, what: str = "--out", replaced: bool = True, expect: tuple[str, ...] = ()
) -> Path:
    """Check, before any work, that a results folder can be written at ``path``; nothing is created.

    Refuses an empty path, the current directory (or one of its ancestors, or the
    home folder) when the folder is ``replaced`` whole, a path under a regular
    file, an existing file where the folder should be, and a location we cannot
    write to (read-only file system, permissions), with one line naming the path.
    With ``expect`` (file names a result of the command has), an existing folder
    with files must hold one of them: a folder that is not an earlier result
    (the user's data, say) is never replaced.

    Returns
    -------
    Path
        ``path`` as given.
    """
    raw = os.fspath(path)
    if not str(raw).strip():
        raise ConfigError(f"{what}: empty path; give a folder")
    p = Path(raw)
    full = p.absolute()
    cwd = Path.cwd().absolute()
    if replaced and full == cwd:
        raise ConfigError(
            f"{what}: {raw}: refusing to write into the current directory (it would be replaced); give a sub-folder"
        )
    if replaced and (full in cwd.parents or full == Path.home().absolute() or full == full.parent):
        raise ConfigError(
            f"{what}: {raw}: refusing to use this folder for results (it would be replaced); give a sub-folder"
        )
    if len(os.fsencode(f".{full.name}.tmp-12345678")) > 255:
        raise ConfigError(f"{what}: folder name of {len(full.name)} characters is too long (keep it under 230)")
    if p.exists():
        if not p.is_dir():
            raise ConfigError(f"{what}: {raw} exists and is not a folder")
        _probe_write(p, f"{what}: {raw}")
        if expect and any(p.iterdir()) and not any((p / name).exists() for name in expect):
            raise ConfigError(
                f"{what}: {raw} holds files but is not an earlier result of this command "
                f"(no {' or '.join(expect)}); give a new or empty folder"
            )
    _check_ancestors(full, what, raw)
    return p


def check_output_file(path: str | os.PathLike, what: str = "--out", suffixes: tuple[str, ...] | None = None) -> Path:
    """Check, before any work, that a file can be written at ``path`` (and its suffix is one of ``suffixes``)."""
    raw = os.fspath(path)
    if not str(raw).strip():
        raise ConfigError(f"{what}: empty path; give a file name")
    p = Path(raw)
    if raw.endswith(("/", os.sep)) or p.is_dir():
        raise ConfigError(f"{what}: {raw} is a folder; give a file name")
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise ConfigError(
            f"{what}: {raw}: unsupported file type {p.suffix or '(none)'!r}; use one of {', '.join(suffixes)}"
        )
    if len(os.fsencode(f".{p.name}.12345678{p.suffix or '.tmp'}")) > 255:
        raise ConfigError(f"{what}: file name of {len(p.name)} characters is too long (keep it under 230)")
    if p.exists() and not p.is_file():
        raise ConfigError(f"{what}: {raw} exists and is not a regular file")
    _check_ancestors(p.absolute(), what, raw)
    return p


@contextlib.contextmanager
def replace_dir(path: str | os.PathLike) -> Iterator[Path]:
    """Write a folder whole or not at all: yield a temporary sibling, swap it in on success.

    Inside the ``with`` block everything is written into ``.<name>.tmp-XXXX``
    next to ``path``. On normal exit the old ``path`` (if any) is renamed away,
    the new folder renamed in, and the old one deleted; on an exception or an
    interrupt (``KeyboardInterrupt``) the temporary folder is deleted and
    ``path`` is left exactly as it was. A re-run therefore never leaves files of
    an earlier run beside the new ones, and a stop at any instant leaves either
    the old result or the new one, complete.

    Yields
    ------
    Path
        The temporary folder to write into (it exists and is empty).
    """
    final = Path(path)
    parent = final.absolute().parent
    parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.tmp-", dir=parent))
    os.chmod(tmp, _dir_mode())
    try:
        yield tmp
        swap_in(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _dir_mode() -> int:
    """Mode an ordinary ``mkdir`` would give (``mkdtemp`` makes folders 0700)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o777 & ~mask


def swap_in(new: Path, final: Path) -> None:
    """Replace folder ``final`` by folder ``new`` (a sibling) with two renames; the old one is deleted last."""
    final = Path(final)
    with sigint_deferred():
        _swap(new, final)


def _swap(new: Path, final: Path) -> None:
    old = None
    if final.exists() or final.is_symlink():
        old = Path(tempfile.mkdtemp(prefix=f".{final.name}.old-", dir=final.absolute().parent))
        os.rmdir(old)
        os.replace(final, old)
    try:
        os.replace(new, final)
    except BaseException:
        if old is not None and not final.exists():
            os.replace(old, final)  # put the old result back
        raise
    if old is not None:
        if old.is_dir() and not old.is_symlink():
            shutil.rmtree(old, ignore_errors=True)
        else:
            old.unlink()


def clean_stale_tmp(path: str | os.PathLike) -> None:
    """Delete ``.<name>.tmp-*`` / ``.<name>.old-*`` siblings a killed process may have left next to ``path``."""
    final = Path(path).absolute()
    if not final.parent.is_dir():
        return
    for p in final.parent.glob(f".{final.name}.*"):
        if p.name.startswith((f".{final.name}.tmp-", f".{final.name}.old-")) and p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
