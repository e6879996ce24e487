"""Compiling numba kernel groups ahead (:mod:`simulation.kernels`)."""

from __future__ import annotations

import pytest

from simulation import kernels


def test_a_group_compiles_and_its_done_file_is_written(tmp_path):
    done = tmp_path / "replay.done"
    assert kernels.main(["replay", "--done", str(done)]) == 0
    assert done.read_text() == "done\n"
    from simulation.discrepancy.replay import play_series

    # the group's kernel is compiled in this process now, for the signature real work asks for
    assert play_series.signatures


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
