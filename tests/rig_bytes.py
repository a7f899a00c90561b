"""The rig's "same bytes as before" checks, made to hold on every CPU (for test_rigsim_laws_v3/_v4/_v5).

Why the bytes depend on the CPU: numpy (2.4) picks some float64 kernels by the machine's SIMD level, and they differ
in the last ulp. ``tanh`` has its own X86_V3 (AVX2) kernel (up to 3 ulp from the X86_V2 one, on 30 % of arguments);
``cosh``, ``sinh``, ``arctan``, ``log1p``, ``exp``, ``log``... have X86_V4 (AVX512) kernels and come from the C
library below it. glibc's ``cosh(0.8245650009422029)`` (in ``shape(0.01)``, used by the v3 draws) is
1.3596570154753469, 0.74 ulp low; the correctly rounded value, one ulp up, gives the v3 draw hash recorded on the
AVX512 machine exactly. In a generated dataset the encoder's quantization (1e-5 m) turns an ulp into a count and the
count into a different current a step later, so a folder's bytes belong to a SIMD level (and C library).

So each check holds a hash per SIMD level it was verified on (numpy's highest X86_Vn found; ``NPY_DISABLE_CPU_FEATURES``
lowers it), and, on a level with none, compares with a digest in ``data/rig_digests.json`` (recorded at the check's
reference commit, the same at ac59446) that does not depend on the CPU:

* draws: the JSON text with its numbers blanked, the count of numbers, of zeros and of negative ones (exactly), and
  the sums of log|x| and of log|x| times a ramp over the numbers (to 1e-9 of the sum; a CPU moves a drawn float by an
  ulp or two, ~1e-16 in log|x|);
* datasets: the same call without the encoder's quantization (``resolution=None``), where CPUs differ by ~1e-13
  (X86_V2 against X86_V3 on one machine: 2.3e-13 of a column's largest value at most): each file's text with its
  numbers blanked (exactly), each CSV column's sums of |x|, x and x times a ramp over the rows (to 1e-9 of the sum
  of |x|), every other number (to 1e-9 relative, 1e-12 absolute).

A hash of values rounded to N digits would not do: among ~1e5 values some lie within an ulp of a rounding boundary.
Run the fallback on an X86_V3 machine with ``NPY_DISABLE_CPU_FEATURES=X86_V3`` (the level becomes X86_V2); print a
dataset's digest with ``python tests/rig_bytes.py FOLDER``.
"""

from __future__ import annotations

import hashlib
import json
import math
import pathlib
import re
import sys
from collections.abc import Mapping
from typing import Any

import numpy as np

#: The levels the hashes given as one string (no per-level dict) were verified on: the same bytes on both.
BOTH = ("X86_V3", "X86_V4")
#: Relative tolerance of the CPU-independent comparison (the CPU's effect is ~1e-13).
RTOL = 1e-9
DIGESTS = pathlib.Path(__file__).with_name("data") / "rig_digests.json"
_NUM = re.compile(r"(?<![\w.])-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?")


def simd_level() -> str | None:
    """numpy's highest x86 SIMD level found on this machine (``X86_V4`` AVX512, ``X86_V3`` AVX2, ...), or None."""
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as found
    except ImportError:  # pragma: no cover - another numpy layout: no level, the CPU-independent comparison
        return None
    return next((lv for lv in ("X86_V4", "X86_V3", "X86_V2") if found.get(lv)), None)


def recorded_hash(recorded: str | Mapping[str, str]) -> str | None:
    """The hash recorded for this machine's level: ``recorded`` is one hash (the same on :data:`BOTH`) or a dict."""
    if isinstance(recorded, str):
        return recorded if simd_level() in BOTH else None
    return recorded.get(simd_level() or "")


def draws_hash(draws: list) -> str:
    """sha256 of ``json.dumps`` of the draws (sorted keys), as recorded."""
    return hashlib.sha256(json.dumps(draws, sort_keys=True).encode()).hexdigest()


def numbers_digest(numbers: list[float]) -> list[float]:
    """Count, zeros, negatives, and the sums of log|x| and of log|x| times a ramp 0..1 over the nonzero numbers."""
    x = np.asarray(numbers, dtype=float)
    lg = np.log(np.abs(x[x != 0]))
    ramp = np.linspace(0.0, 1.0, lg.size)
    return [x.size, int(np.sum(x == 0)), int(np.sum(x < 0)), math.fsum(lg), math.fsum(lg * ramp)]


def draws_digest(draws: list) -> dict[str, Any]:
    """The draws' JSON with the numbers blanked (sha256) and :func:`numbers_digest` of its numbers."""
    text = json.dumps(draws, sort_keys=True)
    numbers = [float(m) for m in _NUM.findall(text)]
    return {"text": hashlib.sha256(_NUM.sub("#", text).encode()).hexdigest(), "numbers": numbers_digest(numbers)}


def _stored(section: str, key: str) -> Any:
    return json.loads(DIGESTS.read_text())[section][key]["digest"]


def assert_same_draws(laws: str, draws: list, recorded: str | Mapping[str, str]) -> None:
    """The draws hash to ``recorded`` on this level, or (a level without a hash) have ``laws``' stored digest."""
    want = recorded_hash(recorded)
    if want is not None:
        assert draws_hash(draws) == want, (laws, simd_level())
        return
    got, ref = draws_digest(draws), _stored("draws", laws)
    assert got["text"] == ref["text"] and got["numbers"][:3] == ref["numbers"][:3], laws
    scale = RTOL * (1.0 + abs(ref["numbers"][3]))
    assert np.all(np.abs(np.subtract(got["numbers"][3:], ref["numbers"][3:])) <= scale), laws


def dataset_hash(folder: pathlib.Path) -> str:
    """sha256 of a folder's files (name, bytes) in sorted order: the hash the tests recorded."""
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            h.update(p.name.encode())
            h.update(p.read_bytes())
    return h.hexdigest()


def digest(folder: pathlib.Path) -> dict[str, dict[str, Any]]:
    """Per file: its text with the numbers blanked (sha256), and its numbers (a CSV's as column sums)."""
    out = {}
    for p in sorted(x for x in folder.rglob("*") if x.is_file()):
        text = p.read_text()
        entry: dict[str, Any] = {"text": hashlib.sha256(_NUM.sub("#", text).encode()).hexdigest()}
        if p.suffix == ".csv":
            x = np.loadtxt(p, delimiter=",", skiprows=1, ndmin=2)
            ramp = np.linspace(0.0, 1.0, x.shape[0])
            entry["columns"] = [[math.fsum(np.abs(c)), math.fsum(c), math.fsum(c * ramp)] for c in x.T]
        else:
            entry["numbers"] = [float(m) for m in _NUM.findall(text)]
        out[p.name] = entry
    return out


def assert_digest(folder: pathlib.Path, want: Mapping[str, Mapping[str, Any]]) -> None:
    """``folder``'s :func:`digest` is ``want``: texts exactly, numbers to :data:`RTOL`."""
    got = digest(folder)
    assert sorted(got) == sorted(want)
    for name, g in got.items():
        w = want[name]
        assert g["text"] == w["text"], name
        if "columns" in w:
            gc, wc = np.array(g["columns"]), np.array(w["columns"])
            assert gc.shape == wc.shape, name
            assert np.all(np.abs(gc - wc) <= RTOL * wc[:, :1] + 1e-300), name
        else:
            assert len(g["numbers"]) == len(w["numbers"]), name
            assert np.allclose(g["numbers"], w["numbers"], rtol=RTOL, atol=1e-12), name


def assert_same_dataset(make, recorded: str | Mapping[str, str], key: str, fingerprint=dataset_hash) -> None:
    """``make(resolution)`` generates a folder: with the encoder's resolution its ``fingerprint`` is the hash
    recorded for this level; on a level without one, without quantization (None) its digest is ``key``'s."""
    from maglev_ocp import constants as k

    want = recorded_hash(recorded)
    if want is not None:
        assert fingerprint(make(k.encoder_resolution)) == want, (key, simd_level())
    else:
        assert_digest(make(None), _stored("datasets", key))


def assert_same_datasets(root: pathlib.Path, cases: Mapping[str, tuple], prefix: str) -> None:
    """:func:`assert_same_dataset` for each ``name -> (effects, seed, recorded)`` of ``cases``: the rig's
    ``generate`` with 2 runs of 2 s under ``root / name``, its digest key ``prefix_name``."""
    from maglev_ocp.rigsim import RigSettings, generate

    for name, (eff, seed, want) in cases.items():

        def make(res, name=name, eff=eff, seed=seed):
            s = RigSettings(n_runs=2, duration=2.0, resolution=res)
            return generate(root / name / str(res), eff, seed=seed, settings=s)

        assert_same_dataset(make, want, f"{prefix}_{name}")


if __name__ == "__main__":
    print(json.dumps(digest(pathlib.Path(sys.argv[1])), indent=1))
