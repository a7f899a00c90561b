"""Compiling a generated folder with its Makefile, and the content-hash build cache.

:func:`build_folder` runs ``make`` in a generated folder (parallel jobs, a
progress bar while the objects compile); :func:`build_cached` writes the
sources into ``<cache>/<hash>/`` and builds there only if that folder has no
library yet, so the same controller design is compiled once per machine. The
cache root is ``$MAGLEV_CODEGEN_CACHE`` or ``~/.cache/maglev-ocp/codegen``.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from ..errors import UserError
from .sources import GeneratedSources

LIBRARY = "libmaglev_controller.so"
HARNESS = "maglev_harness"


def find_compiler() -> str | None:
    """The C compiler to use: ``$CC`` if set and found, else ``cc``, ``gcc`` or ``clang`` on the PATH."""
    for cand in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if cand and shutil.which(cand):
            return cand
    return None


def compiler_id(cc: str) -> str:
    """First line of ``cc --version`` (part of the cache key)."""
    try:
        out = subprocess.run([cc, "--version"], capture_output=True, text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError):
        return cc
    return (out.splitlines() or [cc])[0].strip()


def cache_root() -> Path:
    """Root folder of the build cache (``$MAGLEV_CODEGEN_CACHE`` or ``~/.cache/maglev-ocp/codegen``)."""
    env = os.environ.get("MAGLEV_CODEGEN_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "maglev-ocp" / "codegen"


@dataclass
class BuildResult:
    """A built folder.

    Attributes
    ----------
    folder : Path
        Where the sources and the build products are.
    library : Path
        The shared library with every generated function.
    harness : Path or None
        The harness executable (if built).
    seconds : float
        Wall time of the build (0 when taken from the cache).
    cflags : str
        Compiler flags used.
    cached : bool
        Taken from the cache without compiling.
    """

    folder: Path
    library: Path
    harness: Path | None
    seconds: float
    cflags: str
    cached: bool = False

    def table(self) -> str:
        """Short text view."""
        src = "cache" if self.cached else f"compiled in {self.seconds:.1f} s"
        return f"{self.library} ({src}, CFLAGS={self.cflags!r})"


def build_folder(
    folder: str | os.PathLike,
    cflags: str | None = None,
    jobs: int = 2,
    targets: tuple[str, ...] = (LIBRARY, HARNESS),
    progress: bool = True,
    cc: str | None = None,
) -> BuildResult:
    """Run ``make`` in a generated folder.

    Parameters
    ----------
    folder : path
        A folder written by :meth:`GeneratedSources.save`.
    cflags : str, optional
        Override the Makefile's ``CFLAGS``.
    jobs : int
        Parallel compile jobs (``make -j``).
    targets : tuple of str
        Make targets.
    progress : bool
        Progress bar over the object files.
    cc : str, optional
        Compiler (default :func:`find_compiler`).

    Raises
    ------
    UserError
        No C compiler or ``make``, or the build failed (the compiler's last lines in the message).
    """
    from tqdm.auto import tqdm

    folder = Path(folder)
    cc = cc or find_compiler()
    if cc is None:
        raise UserError("no C compiler found (set CC or install cc/gcc/clang)")
    make = shutil.which("make")
    if make is None:
        raise UserError("'make' not found: install make, or build with CMake (see the folder's README.md)")
    srcs = sorted(p.name for p in folder.glob("*.c"))
    cmd = [make, f"-j{max(int(jobs), 1)}", f"CC={cc}"] + ([f"CFLAGS={cflags}"] if cflags is not None else [])
    cmd += list(targets)
    t0 = time.perf_counter()
    log = tempfile.TemporaryFile(mode="w+")
    proc = subprocess.Popen(cmd, cwd=folder, stdout=log, stderr=subprocess.STDOUT, text=True)
    bar = tqdm(total=len(srcs), desc="compile", unit="obj", disable=not progress, leave=False)
    while proc.poll() is None:
        time.sleep(0.25)
        done = sum((folder / s).with_suffix(".o").exists() for s in srcs)
        bar.update(done - bar.n)
    bar.close()
    log.seek(0)
    out = log.read()
    log.close()
    if proc.returncode != 0:
        tail = " | ".join(line.strip() for line in out.strip().splitlines()[-4:])
        raise UserError(f"build in {folder} failed (make exit {proc.returncode}): {tail}")
    used = cflags if cflags is not None else _makefile_cflags(folder)
    harness = folder / HARNESS if HARNESS in targets else None
    return BuildResult(folder, folder / LIBRARY, harness, time.perf_counter() - t0, used)


def _makefile_cflags(folder: Path) -> str:
    for line in (folder / "Makefile").read_text().splitlines():
        if line.startswith("CFLAGS ?="):
            return line.split("=", 1)[1].strip()
    return ""


def build_cached(
    sources: GeneratedSources,
    cflags: str | None = None,
    jobs: int = 2,
    progress: bool = True,
    root: str | os.PathLike | None = None,
) -> BuildResult:
    """Build ``sources`` in the cache folder named by their content hash (compile only on a miss).

    The key covers every generated file, the compiler's identity and the flags.
    Builds happen in a temporary folder renamed into place when complete, so
    concurrent processes never see a half-built library.
    """
    cc = find_compiler()
    if cc is None:
        raise UserError("no C compiler found (set CC or install cc/gcc/clang)")
    flags = cflags if cflags is not None else sources.cflags
    key = hashlib.sha256(f"{sources.digest}\0{compiler_id(cc)}\0{flags}".encode()).hexdigest()[:20]
    base = Path(root) if root is not None else cache_root()
    final = base / key
    if (final / LIBRARY).exists() and (final / HARNESS).exists():
        return BuildResult(final, final / LIBRARY, final / HARNESS, 0.0, flags, cached=True)
    base.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{key}.", dir=base))
    try:
        sources.save(tmp)
        res = build_folder(tmp, cflags=flags, jobs=jobs, progress=progress, cc=cc)
        try:
            os.rename(tmp, final)
        except OSError:  # another process finished first (or a stale folder): use it if complete
            if not (final / LIBRARY).exists():
                shutil.rmtree(final, ignore_errors=True)
                os.rename(tmp, final)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return BuildResult(final, final / LIBRARY, final / HARNESS, res.seconds, flags, cached=False)


__all__ = [
    "HARNESS",
    "LIBRARY",
    "BuildResult",
    "build_cached",
    "build_folder",
    "cache_root",
    "compiler_id",
    "find_compiler",
]
