"""The numba cache warm-up the whole suite runs first from a clean clone
(tests/numba_warm.py, called by book/conftest.py)."""
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numba_warm


def test_kernel_modules_lists_the_kernel_modules_most_kernels_first():
    mods = numba_warm.kernel_modules()
    assert "trackcore.trackers.hpda_pf" in mods and "trackcore.filters.particle" in mods
    assert "trackcore.stats" not in mods   # no kernel of its own
    counts = [len(numba_warm._JIT.findall(
        (numba_warm.ROOT / (m.replace(".", "/") + ".py")).read_text())) for m in mods]
    assert counts == sorted(counts, reverse=True) and min(counts) >= 1


def test_cache_is_empty_looks_at_numbas_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert numba_warm.cache_is_empty()
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / "m.f-1.py311.nbi").write_bytes(b"")
    assert not numba_warm.cache_is_empty()


def test_run_examples_runs_a_modules_examples_quietly(capsys):
    name, seconds = numba_warm._run_examples("trackcore.core.logmath")
    assert name == "trackcore.core.logmath" and seconds >= 0.0
    assert capsys.readouterr().out == ""
    # a module that cannot be imported is left to test_doctests.py to report
    assert numba_warm._run_examples("trackcore.no_such_module")[0] == "trackcore.no_such_module"


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "2"])
def test_warm_rejects_a_bad_process_count(bad):
    with pytest.raises(ValueError, match="processes"):
        numba_warm.warm(bad)
