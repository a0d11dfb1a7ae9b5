"""Where `mapush tables` draws its figures: forked workers beside the tables, or in turn in its own process."""

from __future__ import annotations

import os
import sys
from concurrent.futures import ProcessPoolExecutor

from mapush.report import tables


def test_figures_are_drawn_by_forked_workers_only_on_several_cores_without_torch(monkeypatch):
    monkeypatch.delitem(sys.modules, "torch", raising=False)
    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    with tables.drawing_pool() as pool:
        assert isinstance(pool, ProcessPoolExecutor)
        assert pool.submit(os.getpid).result() != os.getpid()  # drawn in another process
    monkeypatch.setattr(os, "cpu_count", lambda: 1)
    assert not isinstance(tables.drawing_pool(), ProcessPoolExecutor)
    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    monkeypatch.setitem(sys.modules, "torch", object())  # training ran in this process: its thread pools
    with tables.drawing_pool() as pool:
        assert not isinstance(pool, ProcessPoolExecutor)
        assert pool.submit(os.getpid).result() == os.getpid()
