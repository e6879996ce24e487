"""Numba's on-disk cache of the compiled kernels, cleared when any kernel source changes.

Numba keys each cached function on its own source file alone: a cached caller is not recompiled
when a function it calls or inlines from another file changes. The servo loop inlines the sensors,
the controller, the plant, the model's laws and the kinematics; the plant replay inlines the plant;
the discrepancy replay and the UKF call the laws. A cache left from before such a change would run
the old code, or read the parameter table by its old rows, and give wrong numbers without a word.

:func:`clear_stale_caches` hashes the contents of every file of :data:`KERNEL_SOURCES` into one
stamp and compares it with the stamp stored in each of their cache folders (``__pycache__`` beside
the source, or the folder under ``NUMBA_CACHE_DIR`` that numba uses when that is set). Where the
stamp differs or is missing, it deletes that folder's cached kernels (``*.nbi``, ``*.nbc``), then
writes the new stamp (creating the folder on a fresh checkout, so that kernels cached after it are
known to be the present sources'). :mod:`simulation` calls it when it is imported, before any
kernel is loaded, so a process always compiles or loads kernels of the sources it runs. A folder it
cannot write is left alone (numba then caches in the user's cache folder, keyed on each file as
before).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__all__ = ["KERNEL_SOURCES", "STAMP_NAME", "cache_folders", "clear_stale_caches", "kernel_stamp"]

KERNEL_SOURCES = (
    "kinematics/gravity_closed_form.py",
    "simulation/model/laws.py",
    "simulation/engine/sensors.py",
    "simulation/engine/controller.py",
    "simulation/engine/plant.py",
    "simulation/engine/loop.py",
    "simulation/engine/plant_replay.py",
    "simulation/identification/samples.py",
    "simulation/discrepancy/replay.py",
    "simulation/discrepancy/fitting.py",
    "estimators/ukf/process.py",
)
"""The files that define numba kernels, relative to the folder that holds the packages."""

STAMP_NAME = "kernel_sources.stamp"
"""The stamp's file name in each cache folder."""

ROOT = Path(__file__).resolve().parents[1]


def kernel_stamp(root: Path = ROOT) -> str:
    """SHA-256 of the kernel sources' names and contents under ``root`` (a missing file counts as
    empty, so an install without one of the packages still gets a stamp)."""
    digest = hashlib.sha256()
    for name in KERNEL_SOURCES:
        path = root / name
        digest.update(name.encode())
        digest.update(path.read_bytes() if path.is_file() else b"")
    return digest.hexdigest()


def cache_folders(root: Path = ROOT) -> list[Path]:
    """The folders where numba caches the kernels of :data:`KERNEL_SOURCES` under ``root``, one per
    source folder: beside the sources, or under ``NUMBA_CACHE_DIR`` when that is set."""
    folders = sorted({(root / name).parent for name in KERNEL_SOURCES})
    cache_dir = os.environ.get("NUMBA_CACHE_DIR")
    if not cache_dir:
        return [folder / "__pycache__" for folder in folders]
    out = []
    for folder in folders:
        # numba's own mapping (numba.core.caching._CacheLocator.get_suitable_cache_subpath)
        subpath = os.path.abspath(folder)
        hashed = hashlib.sha1(subpath.encode()).hexdigest()
        out.append(Path(cache_dir) / f"{os.path.split(subpath)[-1]}_{hashed}")
    return out


def clear_stale_caches(root: Path = ROOT) -> list[Path]:
    """Delete the cached kernels of every cache folder whose stamp is not that of the present
    sources, and stamp it. Returns the cache files deleted."""
    stamp = kernel_stamp(root)
    deleted = []
    for folder in cache_folders(root):
        marker = folder / STAMP_NAME
        try:
            if marker.read_text() == stamp:
                continue
        except OSError:
            pass
        try:
            folder.mkdir(parents=True, exist_ok=True)
            for path in sorted(folder.glob("*.nb[ic]")):
                path.unlink(missing_ok=True)
                deleted.append(path)
            partial = folder / f".{STAMP_NAME}.{os.getpid()}"
            partial.write_text(stamp)
            os.replace(partial, marker)
        except OSError:
            continue
    return deleted
