"""Reproducibility on another CPU: the store's float rule (matches, configure), the emulated
CPU without AVX-512 (trackcore.experiments.cpu) and the CI step that uses it."""
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from trackcore.experiments import FLOAT_RTOL, compare_rows, get, matches
from trackcore.experiments.cpu import (
    EMULATED_CPU_ENV,
    MARKER,
    check_emulation,
    emulated_env,
    emulation_state,
)

ROOT = Path(__file__).resolve().parent.parent
CI = ROOT / ".ci" / "run"


def test_matches_is_the_store_rule():
    a = np.array([1.0, 250.0, np.nan, np.inf, 0.0])
    assert matches(a, a.copy())
    assert matches(a, a * np.array([1 + FLOAT_RTOL / 10, 1 - FLOAT_RTOL / 10, 1, 1, 1]))
    assert not matches(a, a * np.array([1 + 10 * FLOAT_RTOL, 1, 1, 1, 1]))
    assert not matches(a, np.array([1.0, 250.0, 0.0, np.inf, 0.0])), "NaN must stay NaN"
    assert not matches(a, np.append(a, 1.0)), "shape"
    assert not matches(np.arange(3), np.arange(3.0)), "dtype"
    assert not matches(np.array([1, 2]), np.array([1, 3])), "integers must be equal"
    with pytest.raises(ValueError, match="rtol"):
        matches(a, a, rtol=-1.0)
    # the same verdicts as compare_rows, which verify_sample uses
    compare_rows({"x": a}, {"x": a * (1 + FLOAT_RTOL / 10)}, 0)


def test_configure_snaps_float_noise_to_the_book_config():
    """A recomputed calibration that reproduces the book's within FLOAT_RTOL selects the
    book's config (and store); a real change does not."""
    e = get("tbd-ext-scen-swerling1")
    sp = e.config.pseudo_sigma
    near = e.configure({"fluctuation": "swerling1", "pseudo_sigma": sp * (1 + 1e-13)})
    assert near is e.config and e.default_path(near) == e.default_path()
    far = e.configure({"fluctuation": "swerling1", "pseudo_sigma": sp * (1 + 1e-4)})
    assert far != e.config and "local" in str(e.default_path(far))
    other = get("tbd-ext-pda-r25").configure({"processing_radius": 1000.0})
    assert other.processing_radius == 1000.0


def test_emulated_env_is_the_one_setting():
    base = {"PATH": "/usr/bin", "NUMBA_CPU_NAME": "host"}
    env = emulated_env("/tmp/cache-x", base=base)
    assert base == {"PATH": "/usr/bin", "NUMBA_CPU_NAME": "host"}, "base must not change"
    assert env["NPY_DISABLE_CPU_FEATURES"] == "X86_V4 AVX512_ICL AVX512_SPR"
    assert env["NUMBA_CPU_NAME"] == "generic" and env["OPENBLAS_CORETYPE"] == "Haswell"
    assert env["NUMBA_CACHE_DIR"] == "/tmp/cache-x" and env[MARKER] == "1"
    assert {k: env[k] for k in EMULATED_CPU_ENV} == EMULATED_CPU_ENV
    with pytest.raises(TypeError, match="cache_dir"):
        emulated_env(None)


def test_check_emulation_names_what_is_not_in_effect():
    host = {"numpy_dispatch": ["X86_V3", "X86_V4", "AVX512_ICL"], "numba_cpu": "host",
            "numba_cache_dir": "", "openblas": {"libopenblas.so": "SkylakeX"}}
    with pytest.raises(RuntimeError) as exc:
        check_emulation(host)
    msg = str(exc.value)
    assert "X86_V4, AVX512_ICL" in msg and "'host'" in msg and "SkylakeX" in msg, msg
    ok = {"numpy_dispatch": ["X86_V3"], "numba_cpu": "generic", "numba_cache_dir": "/c",
          "openblas": {"libopenblas.so": "Haswell"}}
    assert "numba target generic" in check_emulation(ok)


def test_the_emulated_environment_takes_effect_in_a_child(tmp_path):
    """In a process started with emulated_env, numpy's AVX-512 dispatch, OpenBLAS's
    AVX-512 kernels and numba's host target are all off (on any x86-64 host)."""
    code = ("from trackcore.experiments.cpu import check_emulation, emulation_state; "
            "print(check_emulation()); print(emulation_state()['numpy_dispatch'])")
    env = emulated_env(tmp_path, base={**os.environ, "PYTHONPATH": str(ROOT)})
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "numba target generic" in out.stdout, out.stdout
    assert "X86_V4" not in out.stdout.splitlines()[-1], out.stdout
    if "X86_V4" in emulation_state()["numpy_dispatch"]:
        # this host has AVX-512: the setting changed numpy's dispatch
        assert "X86_V4" not in out.stdout


def _ci_verify_commands():
    return [line.strip() for line in CI.read_text().splitlines()
            if "trackcore.experiments verify" in line and not line.strip().startswith("#")]


def test_ci_reverifies_stored_rows_on_the_emulated_cpu():
    """.ci/run has one emulated-CPU verification step, it takes its environment from
    trackcore.experiments.cpu (it does not set the variables itself) and its failure
    fails CI."""
    text = CI.read_text()
    cmds = [c for c in _ci_verify_commands() if "--emulate-cpu" in c]
    assert len(cmds) == 1, _ci_verify_commands()
    args = shlex.split(cmds[0].split("|")[0])
    assert args[:4] == ["python", "-m", "trackcore.experiments", "verify"], args
    assert "--no-progress" in args and not any(a.startswith("--path") for a in args), args
    for var in (*EMULATED_CPU_ENV, "NUMBA_CACHE_DIR"):
        assert not re.search(rf"\b{var}=", text), f".ci/run sets {var} itself"
    # its exit status is checked like pytest's
    step = text[text.index(cmds[0]):]
    assert re.search(r'status=\$\{PIPESTATUS\[0\]\}\s*\n', step), "the status is not kept"
    assert "FAILED: stored rows on the emulated CPU" in step
