"""Typed, validated settings loaded from YAML.

Every settings file (parameters, plant profiles, scenarios, campaigns) is
parsed into a pydantic model that forbids unknown keys. Validation failures are
turned into a single :class:`~maglev_ocp.errors.ConfigError` line naming the
file, the key path and what is allowed.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from .errors import ConfigError

M = TypeVar("M", bound=BaseModel)


class Strict(BaseModel):
    """Base for every settings model: unknown keys are errors, values are checked.

    NaN and infinite numbers are refused in every field (a NaN passes no range
    check in a useful way and an infinite limit is never what a setting means).
    """

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=False, allow_inf_nan=False)


def format_validation_error(err: ValidationError, source: str) -> str:
    """Make a one-line message from a pydantic error: ``file: key.path: what``."""
    parts = []
    for e in err.errors()[:3]:
        loc = ".".join(str(x) for x in e["loc"]) or "<top>"
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            msg = "unknown key"
        elif e["type"] == "missing":
            msg = "required key missing"
        elif e["type"] == "finite_number":
            msg = f"NaN/inf is not allowed (got {e.get('input')!r}); give a finite number"
        parts.append(f"{loc}: {msg}")
    more = f" (+{len(err.errors()) - 3} more)" if len(err.errors()) > 3 else ""
    return f"{source}: " + "; ".join(parts) + more


def parse_model(cls: type[M], data: Any, source: str) -> M:
    """Validate ``data`` as ``cls``; raise :class:`ConfigError` naming ``source``."""
    try:
        return cls.model_validate(data)
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source)) from None


def load_yaml(path: str | os.PathLike) -> Any:
    """Read a YAML file; any read or parse failure becomes a one-line ConfigError."""
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{path}: cannot read: {err.__class__.__name__}: {err}") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        raise ConfigError(f"{path}: YAML does not parse{where}: {problem}") from None


def load_model(cls: type[M], path: str | os.PathLike) -> M:
    """Load a YAML file into the settings model ``cls`` (one-line errors)."""
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
    return parse_model(cls, data, str(path))


def _umask_mode() -> int:
    """File mode an ordinary ``open(..., "w")`` would give (``mkstemp`` makes files 0600)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` via a temporary file and rename.

    A crash or an error part-way never leaves a truncated file, and what was
    there before stays until the new content is complete.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.chmod(tmp, _umask_mode())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def dump_yaml(path: str | os.PathLike, data: Any) -> None:
    """Atomically write ``data`` as YAML."""
    atomic_write_text(path, yaml.safe_dump(data, sort_keys=False))


def atomic_write_bytes(path: str | os.PathLike, fig_or_bytes: Any, **savefig_kw: Any) -> None:
    """Atomically write bytes, or a matplotlib figure (PNG by the path's suffix)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix or ".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            if isinstance(fig_or_bytes, (bytes, bytearray)):
                fh.write(fig_or_bytes)
            else:
                fig_or_bytes.savefig(
                    fh, format=(path.suffix.lstrip(".") or "png"), dpi=savefig_kw.pop("dpi", 110), **savefig_kw
                )
        os.chmod(tmp, _umask_mode())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
