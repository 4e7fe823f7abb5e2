"""``python -m trackcore.experiments {list,run,verify}``: see :mod:`trackcore.experiments`."""
from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time

from . import (
    StaleResultsError,
    VerificationError,
    get,
    load,
    names,
    read_metadata,
    run_experiment,
    status,
    verify_sample,
)


@contextlib.contextmanager
def _executor(args):
    """(executor, description) for --workers / --dask / --scheduler."""
    if args.scheduler:
        from distributed import Client

        with Client(args.scheduler) as client:
            n = len(client.scheduler_info().get("workers", {}))
            yield client.get_executor(), f"dask cluster {args.scheduler} ({n} workers)"
        return
    if args.workers is None or args.workers == 0:
        yield None, "serial"
        return
    if args.dask:
        from distributed import Client, LocalCluster

        with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                          dashboard_address=":0") as cluster, Client(cluster) as client:
            yield client.get_executor(), f"dask LocalCluster ({args.workers} workers)"
        return
    from ..montecarlo import process_pool

    with process_pool(args.workers) as pool:
        yield pool, f"process pool ({args.workers} workers)"


def _overrides(pairs):
    out = {}
    for p in pairs or ():
        if "=" not in p:
            raise SystemExit(f"--set expects key=value, got {p!r}")
        k, v = p.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def _cmd_list(args):
    rows = [("experiment", "runs", "seed", "store", "size", "notebook")]
    for name in names():
        e = get(name)
        path = e.default_path()
        size = f"{path.stat().st_size / 1024:.0f} KiB" if path.exists() else "-"
        rows.append((name, str(e.runs), str(e.seed), status(name), size, e.notebook))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())
    return 0


def _cmd_run(args):
    targets = names() if args.names == ["all"] else args.names
    for name in targets:
        get(name)  # unknown names fail before any work
    if len(targets) > 1 and (args.out or args.set):
        raise SystemExit("--out and --set need a single experiment name")
    with _executor(args) as (ex, desc):
        for name in targets:
            t0 = time.perf_counter()
            res = run_experiment(name, runs=args.runs, seed=args.seed,
                                 overrides=_overrides(args.set), executor=ex,
                                 executor_desc=desc, out=args.out,
                                 progress=not args.no_progress)
            m = res.meta
            print(f"{name}: {m['runs']} runs in {time.perf_counter() - t0:.1f} s wall "
                  f"({m['cpu_seconds']:.1f} s CPU in the runs; {desc}) -> {res.path} "
                  f"({os.path.getsize(res.path) / 1024:.0f} KiB)")
    return 0


def _verify_emulated(argv):
    """``verify --emulate-cpu``: the same command in a child process with the emulated
    CPU's environment (:mod:`trackcore.experiments.cpu`) and a fresh, empty numba cache;
    its exit code."""
    import shutil
    import subprocess
    import tempfile

    from .cpu import emulated_env

    cache = tempfile.mkdtemp(prefix="trackcore-numba-")
    try:
        return subprocess.run([sys.executable, "-m", "trackcore.experiments", *argv],
                              env=emulated_env(cache)).returncode
    finally:
        shutil.rmtree(cache, ignore_errors=True)


def _cmd_verify(args):
    if args.emulate_cpu:
        from .cpu import MARKER, check_emulation

        if os.environ.get(MARKER) != "1":
            return _verify_emulated(args.argv)
        try:
            print(check_emulation(), flush=True)
        except RuntimeError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 1
    targets = args.names or [n for n in names() if get(n).default_path().exists()]
    if not targets:
        print("no stored results to verify")
        return 0
    failed = 0
    with _executor(args) as (ex, desc):
        for name in targets:
            try:
                if args.path:
                    meta = read_metadata(args.path)
                    res = load(name, runs=meta["runs"], seed=meta["seed"], path=args.path,
                               overrides=_overrides(args.set))
                else:
                    res = load(name, runs=read_metadata(get(name).default_path())["runs"]
                               if get(name).default_path().exists() else None)
                t0 = time.perf_counter()
                v = verify_sample(res, fraction=args.fraction, minimum=args.minimum,
                                  executor=ex, progress=not args.no_progress)
                print(f"{v} ({time.perf_counter() - t0:.1f} s, {desc})")
            except (StaleResultsError, VerificationError) as exc:
                failed += 1
                print(f"{name}: FAILED: {exc}", file=sys.stderr)
    return 1 if failed else 0


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m trackcore.experiments",
                                description="The book's Monte Carlo experiments: list them, "
                                            "compute and store their per-run rows, verify "
                                            "stored rows by re-simulation.")
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="registered experiments and the state of their stores")

    def executor_opts(q):
        g = q.add_mutually_exclusive_group()
        g.add_argument("--workers", type=int, metavar="K",
                       help="K worker processes (a forkserver pool; with --dask a Dask "
                            "LocalCluster of K single-threaded workers)")
        g.add_argument("--scheduler", metavar="tcp://host:port",
                       help="run on an existing Dask cluster")
        q.add_argument("--dask", action="store_true",
                       help="with --workers: use a Dask LocalCluster instead of processes")
        q.add_argument("--no-progress", action="store_true", help="no progress bar")

    r = sub.add_parser("run", help="compute an experiment's rows and store them (Parquet)")
    r.add_argument("names", nargs="+", metavar="NAME", help="experiment name(s), or 'all'")
    r.add_argument("--runs", type=int, help="number of runs (default: the book's)")
    r.add_argument("--seed", type=int, help="master seed (default: the book's)")
    r.add_argument("--set", action="append", metavar="key=value",
                   help="override a config field (repeatable)")
    r.add_argument("--out", metavar="PATH", help="store file (default: results/NAME.parquet "
                   "for the book's config, results/local/... otherwise)")
    executor_opts(r)

    v = sub.add_parser("verify", help="re-simulate stored runs and compare them")
    v.add_argument("names", nargs="*", metavar="NAME", help="default: every stored experiment")
    v.add_argument("--fraction", type=float, default=0.01,
                   help="fraction of runs to re-simulate (default 0.01; 1.0 = all)")
    v.add_argument("--minimum", type=int, default=20, help="at least this many runs (20)")
    v.add_argument("--path", help="verify this store file instead of the book's")
    v.add_argument("--set", action="append", metavar="key=value",
                   help="with --path: the config overrides the file was made with")
    v.add_argument("--emulate-cpu", action="store_true",
                   help="as on an x86-64 CPU without AVX-512: numpy's AVX-512 dispatch and "
                        "OpenBLAS's AVX-512 kernels off, numba compiling for a generic CPU "
                        "into a fresh cache (trackcore.experiments.cpu; a child process)")
    executor_opts(v)

    argv = sys.argv[1:] if argv is None else list(argv)
    args = p.parse_args(argv)
    args.argv = argv
    if getattr(args, "dask", False) and not args.workers:
        p.error("--dask needs --workers K")
    try:
        return {"list": _cmd_list, "run": _cmd_run, "verify": _cmd_verify}[args.command](args)
    except (ValueError, TypeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
