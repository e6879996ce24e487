"""Compiling numba kernel groups ahead (:mod:`simulation.kernels`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from simulation import kernels


def test_a_group_compiles_and_its_done_file_is_written(tmp_path):
    done = tmp_path / "replay.done"
    assert kernels.main(["replay", "--done", str(done)]) == 0
    assert done.read_text() == "done\n"
    from simulation.discrepancy.replay import play_series

    # the group's kernel is compiled in this process now, for the signature real work asks for
    assert play_series.signatures


def test_the_replay_group_compiles_the_cable_series_for_the_array_types_a_replay_passes(monkeypatch):
    # numba compiles a kernel anew for arrays of another layout or writability: a warm-up that
    # passes other types leaves every worker to compile the series again at its first replay
    import numba

    from simulation.discrepancy import MeasuredSignals
    from simulation.discrepancy import replay as replay_module
    from simulation.discrepancy.replay import RavenModel
    from studies.common.discrepancy_runs import generate_measured, generator_parameters

    kernel = replay_module.cable_link_series
    seen = []

    def recording(*args):
        seen.append(tuple(numba.typeof(a) for a in args))
        return kernel(*args)

    monkeypatch.setattr(replay_module, "cable_link_series", recording)
    kernels.compile_groups(["replay"])
    warm_up = set(seen)
    seen.clear()
    dataset, _ = generate_measured((), seed=5, duration=5.0)
    monkeypatch.setattr(replay_module, "_SERIES", replay_module._SeriesMemo())
    RavenModel(generator_parameters(()), np.zeros(3)).replay(MeasuredSignals.from_dataset(dataset))
    assert seen and set(seen) <= warm_up, (set(seen) - warm_up)


def test_the_done_file_is_written_when_the_compile_fails(tmp_path, monkeypatch):
    def broken():
        raise RuntimeError("no compiler")

    monkeypatch.setitem(kernels.GROUPS, "replay", broken)
    done = tmp_path / "replay.done"
    with pytest.raises(RuntimeError, match="no compiler"):
        kernels.main(["replay", "--done", str(done)])
    # a process waiting for the cache goes on, and compiles what it needs itself
    assert done.exists()


def test_an_unknown_group_is_refused_by_name(capsys):
    with pytest.raises(ValueError, match=r"unknown kernel groups \['servoo'\]; choose from servo, identification, replay"):
        kernels.compile_groups(["servoo"])
    with pytest.raises(SystemExit) as stop:
        kernels.main(["servoo"])
    assert stop.value.code == 2
    assert "invalid choice: 'servoo'" in capsys.readouterr().err


# The numba cache cleared when a kernel source changes (simulation.numba_cache) ---------------------


def test_every_file_that_compiles_a_numba_kernel_is_a_kernel_source():
    from simulation.numba_cache import KERNEL_SOURCES, ROOT

    packages = ("kinematics", "simulation", "estimators")
    files = [path for package in packages for path in (ROOT / package).rglob("*.py")]
    compiling = sorted(str(path.relative_to(ROOT)) for path in files if "@njit" in path.read_text())
    assert compiling == sorted(KERNEL_SOURCES)


@pytest.fixture
def sources(tmp_path, monkeypatch):
    """A copy of the kernel sources' layout with a cached kernel and a compiled module beside each."""
    from simulation.numba_cache import KERNEL_SOURCES

    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    for name in KERNEL_SOURCES:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(f"# {name}\n")
    return tmp_path


def _cache(root: Path, source: str, suffix: str) -> Path:
    folder = (root / source).parent / "__pycache__"
    folder.mkdir(exist_ok=True)
    path = folder / f"{Path(source).stem}.kernel-10.py311{suffix}"
    path.write_bytes(b"cached")
    return path


def test_a_changed_law_clears_the_cached_loop_that_inlines_it_and_nothing_else(sources):
    from simulation.numba_cache import clear_stale_caches

    loop = _cache(sources, "simulation/engine/loop.py", ".nbc")
    index = _cache(sources, "simulation/engine/loop.py", ".nbi")
    module = _cache(sources, "simulation/engine/loop.py", ".pyc")
    # no stamp yet: what is cached may be of any sources
    assert set(clear_stale_caches(sources)) == {loop, index}
    assert module.exists() and not loop.exists()
    loop, index = (_cache(sources, "simulation/engine/loop.py", s) for s in (".nbc", ".nbi"))
    assert clear_stale_caches(sources) == []
    assert loop.exists() and index.exists()
    # numba would keep the cached loop, whose own file did not change
    (sources / "simulation/model/laws.py").write_text("# laws, edited\n")
    assert loop in clear_stale_caches(sources)
    assert not loop.exists() and not index.exists() and module.exists()
    assert clear_stale_caches(sources) == []


def test_with_numba_cache_dir_the_folders_are_where_numba_caches(sources, monkeypatch, tmp_path):
    from numba.core.caching import _CacheLocator

    from simulation.numba_cache import KERNEL_SOURCES, cache_folders

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    folders = cache_folders(sources)
    source = sources / "simulation/engine/plant.py"
    assert tmp_path / "numba" / _CacheLocator.get_suitable_cache_subpath(str(source)) in folders
    assert len(folders) == len({(sources / name).parent for name in KERNEL_SOURCES})
