"""Every shell example of book/running.md runs as written (or as a cheap variant).

The ``bash`` blocks of the page are parsed; every command line must be handled below:
experiment commands run with ``--runs 1`` into a temporary store directory
(``TRACKCORE_RESULTS``), the cluster example starts a real ``dask scheduler`` and
``dask worker`` on this machine, and the few commands that install, build or execute
notebooks (covered by the README's clean-clone run and by nbval) are listed with the
reason they are not run here.  A new example that fits none of these fails the test.
"""
import os
import re
import shlex
import socket
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "book" / "running.md"
NOT_RUN = {
    "python3 -m venv": "installs the environment (the README's clean-clone run does)",
    "jupyter execute": "executes a notebook (the test suite's nbval run executes it)",
    "pytest ": "runs the test suite on a notebook (the suite's nbval run does)",
    "jupyter-book build": "builds the book (the README's build command)",
    "bash .ci/build_pdf": "builds the whole-book PDF (CI's .ci/run builds and checks it)",
}


def commands():
    text = PAGE.read_text()
    out = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        for line in block.splitlines():
            line = line.split("  #")[0].strip()
            if line and not line.startswith("#"):
                out.append(line)
    return out


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cheap(cmd):
    """The experiment command with 1 run and no progress bar."""
    args = shlex.split(cmd)
    if "--runs" in args:
        args[args.index("--runs") + 1] = "1"
    elif args[3] == "run":
        args += ["--runs", "1"]
    return [sys.executable] + args[1:] + (["--no-progress"] if args[3] != "list" else [])


def test_every_example_is_handled():
    cmds = commands()
    assert len(cmds) >= 8, cmds
    for c in cmds:
        assert c.startswith(("python -m trackcore.experiments", "dask ")) or \
            any(c.startswith(k) for k in NOT_RUN), f"running.md example not tested: {c}"


def test_examples_run_as_written(tmp_path):
    env = dict(os.environ, TRACKCORE_RESULTS=str(tmp_path / "results"))
    cluster = []
    try:
        for c in commands():
            if any(c.startswith(k) for k in NOT_RUN):
                continue
            if c.startswith("dask scheduler"):
                port = _free_port()
                args = shlex.split(c)
                args[args.index("--port") + 1] = str(port)
                args += ["--host", "127.0.0.1", "--dashboard-address", ":0"]
                cluster.append(subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL,
                                                stderr=subprocess.DEVNULL))
                continue
            if c.startswith("dask worker"):
                args = shlex.split(c.replace("SCHEDULER-HOST:8786", f"127.0.0.1:{port}"))
                args[args.index("--nworkers") + 1] = "2"
                args += ["--dashboard-address", ":0"]
                cluster.append(subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL,
                                                stderr=subprocess.DEVNULL))
                time.sleep(8)  # let the workers connect
                continue
            c = c.replace("SCHEDULER-HOST:8786", f"127.0.0.1:{port}") if cluster else c
            r = subprocess.run(_cheap(c), env=env, capture_output=True, text=True, cwd=ROOT,
                               timeout=600)
            assert r.returncode == 0, f"{c}\n{r.stdout}\n{r.stderr}"
            if " list" in c:
                assert "hpda-mc-case1" in r.stdout, r.stdout
            if " verify " in c:
                assert "all match" in r.stdout, r.stdout
            if " --scheduler " in c:
                assert "dask cluster" in r.stdout, r.stdout
    finally:
        for p in reversed(cluster):
            p.terminate()
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
    local = list((tmp_path / "results" / "local").glob("hpda-mc-case1-*-seed20070829.parquet"))
    assert local, "the --set snr=3.16 run should be stored under results/local/"
