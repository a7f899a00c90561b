"""Typed, validated settings loaded from YAML.

Writing results (atomic files, whole folders) is :mod:`maglev_ocp.output`;
SIGINT handling is :mod:`maglev_ocp.interrupts`.

Every settings file (parameters, plant profiles, scenarios, campaigns) is
parsed into a pydantic model that forbids unknown keys. Validation failures are
turned into a single :class:`~maglev_ocp.errors.ConfigError` line naming the
file, the key path and what is allowed.
"""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path
from typing import Any, TypeVar, get_args, get_origin

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

from .errors import ConfigError

M = TypeVar("M", bound=BaseModel)

#: Deepest nesting of mappings / lists a settings file may have (a scenario needs about 6).
MAX_YAML_DEPTH: int = 64
#: Largest settings file read [bytes] (the shipped ones are a few kB).
MAX_YAML_BYTES: int = 8 * 1024 * 1024


class Strict(BaseModel):
    """Base for every settings model: unknown keys are errors, values are checked.

    NaN and infinite numbers are refused in every field (a NaN passes no range
    check in a useful way and an infinite limit is never what a setting means),
    and so is ``true`` / ``false`` where a number is expected (Python's bool is
    an int, so ``seed: true`` would otherwise be taken as seed 1).
    """

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=False, allow_inf_nan=False)

    @model_validator(mode="before")
    @classmethod
    def _no_bool_for_a_number(cls, data: Any) -> Any:
        """``true`` / ``false`` given for a number is handed on as text, so the field's own check refuses it."""
        if not isinstance(data, dict):
            return data
        out = data
        for key, v in data.items():
            field = cls.model_fields.get(key) if isinstance(key, str) else None
            if isinstance(v, bool) and field is not None and _takes_number_not_bool(field.annotation):
                out = {**out, key: f"{str(v).lower()} (a boolean, not a number)"}
        return out


def _annotation_types(ann: Any) -> set[Any]:
    """The plain types an annotation admits (``int | None`` -> ``{int, NoneType}``)."""
    args = get_args(ann)
    if not args:
        return {ann}
    out: set[Any] = set()
    for a in args:
        out |= _annotation_types(a)
    return out


def _takes_number_not_bool(ann: Any) -> bool:
    """The field takes an int or a float but not a bool (where ``true`` must be refused)."""
    types = _annotation_types(ann)
    return bool(types & {int, float}) and not types & {bool, str} and get_origin(ann) not in (list, dict, tuple)


def format_validation_error(err: ValidationError, source: str, prefix: str = "") -> str:
    """Make a one-line message from a pydantic error: ``file: key.path: what`` (``prefix`` before each key)."""
    parts = []
    for e in err.errors()[:3]:
        loc = prefix + (".".join(str(x) for x in e["loc"]) or "<top>")
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            msg = "unknown key"
        elif e["type"] == "missing":
            msg = "required key missing"
        elif isinstance(e.get("input"), str) and e["input"].endswith("(a boolean, not a number)"):
            msg = f"{e['input'].split()[0]} is a boolean, not a number; give a number"
        elif e["type"] == "finite_number" or (isinstance(e.get("input"), float) and math.isnan(e["input"])):
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


class _YamlTooDeep(yaml.YAMLError):
    """Raised by :class:`_StrictLoader` when the nesting exceeds :data:`MAX_YAML_DEPTH`."""


class _StrictLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses duplicate keys and nesting deeper than :data:`MAX_YAML_DEPTH`.

    PyYAML composes nested nodes recursively, so a deeply nested file would end
    in a ``RecursionError``; counting the depth here stops it with a message
    that says the limit. A key given twice in one mapping is an error naming the
    key and its line (PyYAML would silently keep the last value).
    """

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                mark = self.peek_event().start_mark
                raise _YamlTooDeep(
                    f"nested deeper than {MAX_YAML_DEPTH} levels (line {mark.line + 1}); the limit is {MAX_YAML_DEPTH}"
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        if isinstance(node, yaml.MappingNode):
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    dup = key in seen
                    seen.add(key)
                except TypeError:  # unhashable key: the base constructor reports it
                    continue
                if dup:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"duplicate key {key!r} (line {key_node.start_mark.line + 1})", key_node.start_mark
                    )
        return super().construct_mapping(node, deep=deep)


def parse_yaml_text(text: str, source: str) -> Any:
    """Parse YAML ``text`` (from ``source``, for messages) with the strict loader; one-line ConfigError on failure.

    A UTF-8 byte-order mark is dropped; duplicate keys, nesting deeper than
    :data:`MAX_YAML_DEPTH` and anything PyYAML refuses are errors.
    """
    text = text.removeprefix("\ufeff")
    try:
        return yaml.load(text, Loader=_StrictLoader)
    except _YamlTooDeep as err:
        raise ConfigError(f"{source}: YAML {err}") from None
    except RecursionError:
        raise ConfigError(f"{source}: YAML nested too deeply (limit {MAX_YAML_DEPTH} levels)") from None
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        raise ConfigError(f"{source}: YAML does not parse{where}: {problem}") from None


def load_yaml(path: str | os.PathLike) -> Any:
    """Read a YAML file; any read or parse failure becomes a one-line ConfigError."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_YAML_BYTES:
            raise ConfigError(f"{path}: larger than {MAX_YAML_BYTES // 2**20} MB, the limit for a settings file")
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{path}: cannot read: {err.__class__.__name__}: {err}") from None
    return parse_yaml_text(text, str(path))


def load_model(cls: type[M], path: str | os.PathLike) -> M:
    """Load a YAML file into the settings model ``cls`` (one-line errors)."""
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
    return parse_model(cls, data, str(path))


#: Names that moved to :mod:`maglev_ocp.output` (imported from here they still work, with a DeprecationWarning).
_MOVED_TO_OUTPUT = (
    "atomic_write_text",
    "atomic_write_bytes",
    "dump_yaml",
    "plain_data",
    "make_dir",
    "check_output_dir",
    "check_output_file",
    "replace_dir",
    "swap_in",
    "clean_stale_tmp",
)


def __getattr__(name: str) -> Any:
    """Old imports of the output helpers (``from maglev_ocp.config import replace_dir``) keep working."""
    if name in _MOVED_TO_OUTPUT or name == "sigint_ignored":
        module = "interrupts" if name == "sigint_ignored" else "output"
        warnings.warn(f"maglev_ocp.config.{name} moved to maglev_ocp.{module}.{name}", DeprecationWarning, stacklevel=2)
        from importlib import import_module

        return getattr(import_module(f"maglev_ocp.{module}"), name)
    raise AttributeError(f"module 'maglev_ocp.config' has no attribute {name!r}")
