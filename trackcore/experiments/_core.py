"""Experiments, their Parquet stores, loading with staleness checks, sampled verification.

See the package docstring (:mod:`trackcore.experiments`) for the design.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import random
import subprocess
import sys
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .. import __version__
from ..core.rng import generator_for_run
from ..core.validation import as_count, as_int

#: Relative tolerance of :func:`verify_sample` for floating-point columns.  Another CPU
#: rounds some sums differently in the last bits, and a trajectory can amplify that: on an
#: emulated CPU without AVX-512, 999 of the 1000 runs of ``tbd-tracking-main-25`` agreed to
#: 1.4e-10, and one (run 802, a lost track whose Kalman filter coasts 4-9 km from the target
#: for 150 scans) drifted to 4.9e-9.  1e-6 leaves a 200-fold margin above that and is still
#: far below any change of a result.
FLOAT_RTOL = 1e-6
#: Metadata key of a store file (Parquet key-value metadata, JSON value).
META_KEY = b"trackcore.experiment"
#: The package's repository root (the default store lives in ``<root>/results``).
_REPO_ROOT = Path(__file__).resolve().parents[2]


class StaleResultsError(LookupError):
    """A store is missing, or was made for another configuration, seed or version.

    ``command`` is the exact shell command that regenerates it.

    Examples
    --------
    Raised by :func:`load` for a store that does not fit; the message ends with the
    command that regenerates it:

    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> import tempfile
    >>> tmp = tempfile.TemporaryDirectory()
    >>> res = run_experiment(toy, out=Path(tmp.name) / "toy.parquet", progress=False)
    >>> load(toy, runs=50, path=res.path)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    trackcore.experiments._core.StaleResultsError: The stored results ... of 'toy' are stale: it holds 20 runs, 50 are requested.
    Regenerate it with:
        python -m trackcore.experiments run toy --runs 50 --out .../toy.parquet
    >>> tmp.cleanup()
    """

    def __init__(self, message, command):
        super().__init__(f"{message}\nRegenerate it with:\n    {command}")
        self.command = command


class MissingResultsError(StaleResultsError):
    """No store file at the expected path.

    Examples
    --------
    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> try:
    ...     load(toy, path="no-such-dir/toy.parquet")
    ... except MissingResultsError as exc:
    ...     print(exc.command)
    python -m trackcore.experiments run toy --out no-such-dir/toy.parquet
    >>> issubclass(MissingResultsError, StaleResultsError)
    True
    """


class VerificationError(AssertionError):
    """A re-simulated run does not reproduce its stored row.

    Examples
    --------
    Raised by :func:`compare_rows` (and so :func:`verify_sample`) at the first mismatch:

    >>> compare_rows({"x": np.float64(1.0)}, {"x": np.float64(1.1)}, run=3)
    Traceback (most recent call last):
        ...
    trackcore.experiments._core.VerificationError: run 3, column 'x': stored np.float64(1.0), recomputed np.float64(1.1) (relative tolerance 1e-06)
    """


def results_dir() -> Path:
    """The store directory: ``$TRACKCORE_RESULTS`` if set, else ``<repository>/results``.

    Examples
    --------
    >>> import os
    >>> os.environ.get("TRACKCORE_RESULTS") or results_dir().name
    'results'
    """
    env = os.environ.get("TRACKCORE_RESULTS")
    return Path(env) if env else _REPO_ROOT / "results"


def _canonical(value):
    """A JSON-ready, order-stable form of a config value."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _canonical(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, (tuple, list)):
        return [_canonical(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _canonical(v) for k, v in sorted(value.items())}
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating,)):
        return float(value)
    return value


def _same_config(book, other, rtol=FLOAT_RTOL) -> bool:
    """Whether config ``other`` equals ``book`` with floats compared by the store's rule:
    within relative ``rtol`` of the book's value; every other field equal."""
    if type(book) is not type(other):
        return False
    if dataclasses.is_dataclass(book) and not isinstance(book, type):
        return all(_same_config(getattr(book, f.name), getattr(other, f.name), rtol)
                   for f in dataclasses.fields(book))
    if isinstance(book, (tuple, list)):
        return len(book) == len(other) and all(_same_config(a, b, rtol)
                                               for a, b in zip(book, other))
    if isinstance(book, (float, np.floating)):
        return bool(book == other or abs(other - book) <= rtol * abs(book))
    return bool(book == other)


def config_hash(config) -> str:
    """SHA-256 (hex, 16 digits) of the canonical JSON of a config record.

    Examples
    --------
    The hash identifies a config: it changes with any field and names the local stores:

    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> config_hash(Toy()), config_hash(Toy(mean=2.0))
    ('0dcd7403a9d0603b', 'f4273bd42fd4dd63')
    >>> toy.default_path(Toy(mean=2.0)).name
    'toy-f4273bd42fd4dd63-seed7.parquet'
    """
    text = json.dumps(_canonical(config), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def code_version() -> str:
    """``trackcore <version>`` plus the git commit (``+dirty`` if trackcore/ has changes).

    Recorded in every store for the record; it is *not* part of the staleness check
    (it changes with every commit): the sampled re-simulation catches code drift.

    Examples
    --------
    >>> code_version()  # doctest: +ELLIPSIS
    'trackcore ...'
    """
    out = f"trackcore {__version__}"
    try:
        head = subprocess.run(["git", "-C", str(_REPO_ROOT), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, timeout=10)
        if head.returncode == 0:
            out += f" git {head.stdout.strip()}"
            dirty = subprocess.run(["git", "-C", str(_REPO_ROOT), "status", "--porcelain",
                                    "trackcore"], capture_output=True, text=True, timeout=10)
            if dirty.returncode == 0 and dirty.stdout.strip():
                out += "+dirty"
    except (OSError, subprocess.SubprocessError):
        pass
    return out


@dataclass(frozen=True)
class Experiment:
    """A named Monte Carlo experiment of the book.

    ``trial(rng, *args, **kwargs)`` is an existing trackcore trial; ``call(config)``
    maps a config record to its ``(args, kwargs)``; ``extract(result, config)`` maps
    one trial result to a flat row ``{column: scalar or fixed-shape ndarray}``.
    ``config`` is the book's config record (a frozen dataclass that validates itself),
    ``seed`` and ``runs`` the book's master seed and run count.  Run ``i`` uses
    ``numpy.random.default_rng(SeedSequence(seed).spawn(n)[i])`` exactly as
    :func:`trackcore.montecarlo.run` does, which does not depend on ``n``: the first
    ``m`` rows of a store of ``n >= m`` runs are the rows of an ``m``-run experiment.
    ``version`` is bumped by hand whenever the trial's or the extractor's meaning
    changes; a store with another version is refused.

    Examples
    --------
    A toy experiment, not registered (:func:`register` adds one to the book's list):
    run ``i`` draws one normal number with ``rng`` seeded from ``(seed, i)``.

    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> toy.row(np.random.default_rng(0), toy.config)
    {'x': 1.1257302210933933}
    >>> toy.default_path().relative_to(results_dir())
    PosixPath('toy.parquet')
    >>> toy.command(runs=50, seed=1)
    'python -m trackcore.experiments run toy --runs 50 --seed 1'
    """

    name: str
    description: str
    trial: Callable
    call: Callable
    extract: Callable
    config: Any
    seed: int
    runs: int
    version: str
    notebook: str = ""

    def configure(self, overrides=None):
        """The book's config with ``overrides`` ({field: value}) applied and validated.

        A config that equals the book's except for floats within ``FLOAT_RTOL`` of the
        book's values *is* the book's config (the book's record is returned): a field a
        page recomputes before passing it (a calibrated noise level) then selects the
        book's store on any CPU, where its last bits may differ (numpy's and OpenBLAS's
        kernels with and without AVX-512 round differently); the store's own rule for
        floats, :func:`matches`, decides, and any larger change selects another config.
        """
        if not overrides:
            return self.config
        if not isinstance(overrides, dict):
            raise TypeError(f"overrides must be a dict, got {type(overrides).__name__}")
        config = self.config.with_overrides(overrides)
        return self.config if _same_config(self.config, config) else config

    def row(self, rng, config):
        """One run: the trial's result reduced to its row."""
        args, kwargs = self.call(config)
        return self.extract(self.trial(rng, *args, **kwargs), config)

    def default_path(self, config=None, seed=None) -> Path:
        """``results/NAME.parquet`` for the book's config and seed; otherwise
        ``results/local/NAME-<config hash>-seed<seed>.parquet`` (not in git)."""
        config = self.config if config is None else config
        seed = self.seed if seed is None else seed
        if config == self.config and seed == self.seed:
            return results_dir() / f"{self.name}.parquet"
        return results_dir() / "local" / f"{self.name}-{config_hash(config)}-seed{seed}.parquet"

    def command(self, runs=None, seed=None, overrides=None, path=None) -> str:
        """The CLI command that computes this experiment's store."""
        cmd = f"python -m trackcore.experiments run {self.name}"
        if runs is not None and runs != self.runs:
            cmd += f" --runs {runs}"
        if seed is not None and seed != self.seed:
            cmd += f" --seed {seed}"
        for k, v in (overrides or {}).items():
            cmd += f" --set {k}={_format_value(v)}"
        if path is not None:
            config = self.configure(overrides)
            if Path(path).resolve() != self.default_path(config, seed).resolve():
                cmd += f" --out {path}"
        return cmd


def _format_value(v):
    if isinstance(v, (tuple, list)):
        return ",".join(str(x) for x in v)
    return str(v)


# ---------------------------------------------------------------------------- computing rows
def _row_task(rng, experiment, config):
    """Executed where the run goes: the row and the CPU time it took."""
    t0 = time.process_time()
    row = experiment.row(rng, config)
    return row, time.process_time() - t0


def _rows_for_indices(experiment, config, seed, n, indices):
    """Worker side of :func:`compute_rows` for arbitrary run indices: run ``i`` gets
    ``generator_for_run(seed, i, n)`` (the ``i``-th of ``n`` spawned streams, built alone:
    spawning all ``n`` for every verified run cost 0.45 s per run at 40 000 runs)."""
    return [_row_task(generator_for_run(seed, i, n), experiment, config) for i in indices]


def _progress_bar(total, desc, enabled):
    """A text progress bar on ``sys.stderr`` (tqdm's plain bar: in a terminal and in a
    notebook cell alike, where tqdm's widget bar would need ipywidgets), or None."""
    if not enabled:
        return None
    from tqdm.std import tqdm
    return tqdm(total=total, desc=desc, unit="run", file=sys.stderr, smoothing=0.1,
                mininterval=1.0, bar_format="{l_bar}{bar:20}| {n_fmt}/{total_fmt} "
                                            "[{elapsed}<{remaining}, {rate_fmt}]")


def compute_rows(experiment, config, seed, runs, *, indices=None, executor=None,
                 progress=False):
    """Rows of runs ``0 .. runs-1`` (or of ``indices``) and the total CPU seconds.

    All runs go through :func:`trackcore.montecarlo.run` (same seeding); ``indices``
    re-computes chosen runs of a ``runs``-run experiment the same way.

    Examples
    --------
    Rows do not depend on how many runs are asked for: run 2 alone is run 2 of three:

    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> rows, cpu_seconds = compute_rows(toy, toy.config, seed=7, runs=3)
    >>> [round(r["x"], 4) for r in rows]
    [0.3699, 2.4019, 1.0395]
    >>> rows, _ = compute_rows(toy, toy.config, seed=7, runs=20, indices=[2])
    >>> round(rows[0]["x"], 4)
    1.0395
    """
    from .. import montecarlo

    runs = as_count(runs, "runs")
    bar = _progress_bar(runs if indices is None else len(indices), experiment.name, progress)

    def report(done, total):
        if bar is not None:
            bar.update(done - bar.n)

    try:
        if indices is None:
            pairs = montecarlo.run(_row_task, runs, seed, executor=executor, progress=report,
                                   args=(experiment, config))
        else:
            idx = [as_int(i, "index", minimum=0) for i in indices]
            if any(i >= runs for i in idx):
                raise ValueError(f"indices must lie in [0, {runs})")
            if executor is None:
                pairs = []
                for k, i in enumerate(idx):
                    pairs += _rows_for_indices(experiment, config, seed, runs, [i])
                    report(k + 1, len(idx))
            else:
                futs = [executor.submit(_rows_for_indices, experiment, config, seed, runs, [i])
                        for i in idx]
                pairs = []
                for k, f in enumerate(futs):
                    pairs += f.result()
                    report(k + 1, len(idx))
    finally:
        if bar is not None:
            bar.close()
    rows = [r for r, _ in pairs]
    return rows, float(sum(c for _, c in pairs))


# ------------------------------------------------------------------------------- the store
def _columns(rows):
    """Stack rows into ``{column: array (runs, *shape)}``, checking consistent shapes."""
    if not rows:
        raise ValueError("no rows to store")
    names = list(rows[0])
    cols = {}
    for name in names:
        vals = [np.asarray(r[name]) for r in rows]
        first = vals[0]
        for i, v in enumerate(vals):
            if v.shape != first.shape or v.dtype != first.dtype:
                raise ValueError(f"column {name!r}: run {i} has {v.dtype} {v.shape}, "
                                 f"run 0 has {first.dtype} {first.shape}")
        cols[name] = np.stack(vals)
    return cols


def write_store(path, experiment, config, seed, rows, *, wall_seconds, cpu_seconds,
                executor_desc="serial"):
    """Write ``rows`` to a Parquet file with the experiment's metadata; returns the path.

    Examples
    --------
    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> import tempfile
    >>> rows, cpu = compute_rows(toy, toy.config, seed=7, runs=3)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_store(Path(tmp) / "toy.parquet", toy, toy.config, 7, rows,
    ...                        wall_seconds=0.1, cpu_seconds=cpu)
    ...     meta = read_metadata(path)
    >>> meta["experiment"], meta["runs"], meta["seed"], meta["config"], meta["columns"]
    ('toy', 3, 7, {'mean': 1.0}, {'x': [[], '<f8']})
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    cols = _columns(rows)
    n = len(rows)
    arrays, fields, shapes = [], [], {}
    arrays.append(pa.array(np.arange(n, dtype=np.int64)))
    fields.append(pa.field("run", pa.int64()))
    for name, a in cols.items():
        shape = a.shape[1:]
        shapes[name] = [list(shape), a.dtype.str]
        flat = np.ascontiguousarray(a).reshape(n, -1) if shape else a
        if shape:
            size = int(np.prod(shape))
            values = pa.array(flat.reshape(-1))
            arr = pa.FixedSizeListArray.from_arrays(values, size)
        else:
            arr = pa.array(a)
        arrays.append(arr)
        fields.append(pa.field(name, arr.type))
    meta = {
        "experiment": experiment.name,
        "version": experiment.version,
        "config": _canonical(config),
        "config_hash": config_hash(config),
        "seed": int(seed),
        "runs": n,
        "code_version": code_version(),
        "created_utc": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M:%S"),
        "wall_seconds": round(float(wall_seconds), 2),
        "cpu_seconds": round(float(cpu_seconds), 2),
        "executor": executor_desc,
        "python": sys.version.split()[0],
        "columns": shapes,
    }
    schema = pa.schema(fields, metadata={META_KEY: json.dumps(meta).encode()})
    table = pa.Table.from_arrays(arrays, schema=schema)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    # floats: byte-stream-split encoding (their bytes grouped by significance, which zstd
    # compresses far better than dictionaries of distinct values); others: dictionaries
    paths = {name: name + (".list.element" if shapes[name][0] else "") for name in cols}
    floats = [paths[k] for k, a in cols.items() if np.issubdtype(a.dtype, np.floating)]
    others = ["run"] + [paths[k] for k in cols if paths[k] not in floats]
    pq.write_table(table, tmp, compression="zstd", compression_level=19,
                   use_dictionary=others, use_byte_stream_split=floats or False)
    os.replace(tmp, path)
    return path


def read_metadata(path) -> dict:
    """The metadata of a store file (no data read).

    Examples
    --------
    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> import tempfile
    >>> tmp = tempfile.TemporaryDirectory()
    >>> res = run_experiment(toy, out=Path(tmp.name) / "toy.parquet", progress=False)
    >>> meta = read_metadata(res.path)
    >>> meta["experiment"], meta["version"], meta["runs"], meta["config_hash"]
    ('toy', '1', 20, '0dcd7403a9d0603b')
    >>> tmp.cleanup()
    """
    import pyarrow.parquet as pq

    md = pq.read_schema(path).metadata or {}
    if META_KEY not in md:
        raise ValueError(f"{path} is not a trackcore experiment store (no {META_KEY!r} metadata)")
    return json.loads(md[META_KEY])


class Results:
    """Stored rows of one experiment: ``res[column]`` is an array with runs first.

    Examples
    --------
    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> import tempfile
    >>> tmp = tempfile.TemporaryDirectory()
    >>> res = run_experiment(toy, out=Path(tmp.name) / "toy.parquet", progress=False)
    >>> res.runs, "x" in res, res.is_book
    (20, True, True)
    >>> np.round(res["x"][:3], 4)
    array([0.3699, 2.4019, 1.0395])
    >>> res["y"]
    Traceback (most recent call last):
        ...
    KeyError: "toy has no column 'y'; columns: ['run', 'x']"
    >>> tmp.cleanup()
    """

    def __init__(self, experiment, meta, columns, path, config, from_store=True):
        self.experiment = experiment
        self.config = config
        self.meta = meta
        self.columns = columns
        self.path = path
        self.from_store = from_store

    @property
    def runs(self) -> int:
        return len(self.columns["run"])

    @property
    def is_book(self) -> bool:
        """Whether these are the book's runs: its config, seed and run count."""
        e = self.experiment
        return (self.config == e.config and self.meta.get("seed") == e.seed
                and self.runs == e.runs)

    def __getitem__(self, name):
        try:
            return self.columns[name]
        except KeyError:
            raise KeyError(f"{self.experiment.name} has no column {name!r}; columns: "
                           f"{sorted(self.columns)}") from None

    def __contains__(self, name):
        return name in self.columns

    def row(self, i):
        """Run ``i``'s row as ``{column: value}`` (without the ``run`` column)."""
        return {k: v[i] for k, v in self.columns.items() if k != "run"}

    def __repr__(self):
        return (f"Results({self.experiment.name!r}, runs={self.runs}, "
                f"columns={len(self.columns) - 1}, path={str(self.path)!r})")


def _read_columns(path, runs=None):
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    meta = json.loads(table.schema.metadata[META_KEY])
    n = table.num_rows if runs is None else runs
    cols = {"run": table.column("run").to_numpy()[:n]}
    for name, (shape, dtype) in meta["columns"].items():
        col = table.column(name).combine_chunks()
        if shape:
            values = col.flatten().to_numpy(zero_copy_only=False)
            a = values.reshape(table.num_rows, *shape)
        else:
            a = col.to_numpy(zero_copy_only=False)
        cols[name] = np.ascontiguousarray(a[:n]).astype(np.dtype(dtype), copy=False)
    return meta, cols


def check_store(experiment, path, config, seed, runs):
    """Raise :class:`StaleResultsError` unless ``path`` holds at least ``runs`` runs of
    ``experiment`` at ``config``, ``seed`` and the current version; returns its metadata.

    Examples
    --------
    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> import tempfile
    >>> tmp = tempfile.TemporaryDirectory()
    >>> res = run_experiment(toy, out=Path(tmp.name) / "toy.parquet", progress=False)
    >>> check_store(toy, res.path, toy.config, seed=7, runs=10)["runs"]
    20
    >>> check_store(toy, res.path, toy.config, seed=8, runs=10)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    trackcore.experiments._core.StaleResultsError: The stored results ... are stale: its seed is 7, not 8.
    Regenerate it with:
        python -m trackcore.experiments run toy --runs 10 --seed 8 --out .../toy.parquet
    >>> tmp.cleanup()
    """
    overrides = _overrides_of(experiment, config)
    cmd = experiment.command(max(runs, experiment.runs) if config == experiment.config
                             and seed == experiment.seed else runs, seed, overrides, path)
    path = Path(path)
    if not path.exists():
        raise MissingResultsError(f"No stored results for experiment {experiment.name!r} at "
                                  f"{path}.", cmd)
    meta = read_metadata(path)
    problems = []
    if meta.get("experiment") != experiment.name:
        problems.append(f"it holds experiment {meta.get('experiment')!r}")
    if meta.get("version") != experiment.version:
        problems.append(f"it was made by version {meta.get('version')!r} of the experiment, "
                        f"the code is at version {experiment.version!r}")
    if meta.get("config_hash") != config_hash(config):
        problems.append(f"its config {meta.get('config')} is not the requested "
                        f"{_canonical(config)}")
    if meta.get("seed") != seed:
        problems.append(f"its seed is {meta.get('seed')}, not {seed}")
    if meta.get("runs", 0) < runs:
        problems.append(f"it holds {meta.get('runs')} runs, {runs} are requested")
    if problems:
        raise StaleResultsError(f"The stored results {path} of {experiment.name!r} are stale: "
                                + "; ".join(problems) + ".", cmd)
    return meta


def _overrides_of(experiment, config):
    """The {field: value} overrides that turn the book's config into ``config``."""
    base, out = experiment.config, {}
    for f in dataclasses.fields(config):
        v = getattr(config, f.name)
        if v != getattr(base, f.name):
            out[f.name] = v
    return out


def load(name, *, runs=None, seed=None, overrides=None, path=None) -> Results:
    """Load an experiment's stored rows (the first ``runs`` of them).

    Defaults: the book's run count, seed and config, and the store at
    :meth:`Experiment.default_path`.  Raises :class:`StaleResultsError` (with the command
    that regenerates the store) if the file is missing or was made for another config,
    seed or experiment version, or holds fewer runs.

    Examples
    --------
    The first ``runs`` rows of a store (here a temporary one; by default the book's):

    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> import tempfile
    >>> tmp = tempfile.TemporaryDirectory()
    >>> res = run_experiment(toy, out=Path(tmp.name) / "toy.parquet", progress=False)
    >>> first = load(toy, runs=5, path=res.path)
    >>> first.runs, np.round(first["x"][:3], 4)
    (5, array([0.3699, 2.4019, 1.0395]))
    >>> tmp.cleanup()
    """
    experiment = get(name)
    config = experiment.configure(overrides)
    seed = experiment.seed if seed is None else as_int(seed, "seed", minimum=0)
    runs = experiment.runs if runs is None else as_int(runs, "runs", minimum=1)
    path = Path(path) if path is not None else experiment.default_path(config, seed)
    check_store(experiment, path, config, seed, runs)
    meta, cols = _read_columns(path, runs)
    return Results(experiment, meta, cols, path, config)


def run_experiment(name, *, runs=None, seed=None, overrides=None, executor=None,
                   executor_desc=None, out=None, progress=True, write=True) -> Results:
    """Compute an experiment's rows (on ``executor``) and, with ``write``, store them.

    Examples
    --------
    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> res = run_experiment(toy, runs=4, write=False, progress=False)
    >>> res.runs, res.from_store, np.round(res["x"], 4)
    (4, False, array([ 0.3699,  2.4019,  1.0395, -0.0158]))
    """
    experiment = get(name)
    config = experiment.configure(overrides)
    seed = experiment.seed if seed is None else as_int(seed, "seed", minimum=0)
    runs = experiment.runs if runs is None else as_int(runs, "runs", minimum=1)
    t0 = time.perf_counter()
    rows, cpu = compute_rows(experiment, config, seed, runs, executor=executor,
                             progress=progress)
    wall = time.perf_counter() - t0
    desc = executor_desc or ("serial" if executor is None else type(executor).__name__)
    path = None
    if write:
        path = Path(out) if out is not None else experiment.default_path(config, seed)
        write_store(path, experiment, config, seed, rows, wall_seconds=wall, cpu_seconds=cpu,
                    executor_desc=desc)
        meta, cols = _read_columns(path)
        return Results(experiment, meta, cols, path, config)
    cols = {"run": np.arange(runs, dtype=np.int64), **_columns(rows)}
    meta = {"experiment": name, "version": experiment.version, "config": _canonical(config),
            "config_hash": config_hash(config), "seed": seed, "runs": runs,
            "wall_seconds": wall, "cpu_seconds": cpu, "executor": desc}
    return Results(experiment, meta, cols, None, config, from_store=False)


def obtain(name, *, runs=None, seed=None, overrides=None, executor=None):
    """What a notebook's parameters cell asks for, from the store when it can be.

    The book's config and seed: the stored rows (strict: a missing or stale store raises
    :class:`StaleResultsError` with its regenerate command).  Any other config or seed:
    a store the reader made with the CLI (``results/local/``) if it holds enough runs,
    else a live computation; either way a note says that the book's stored results were
    not used.  A smaller run count of the book's config uses the first ``runs`` stored
    rows, with a note.

    Examples
    --------
    The book's config needs its store (here there is none); another seed is computed
    now, with a note:

    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> obtain(toy)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    trackcore.experiments._core.MissingResultsError: No stored results for experiment 'toy' at .../toy.parquet.
    Regenerate it with:
        python -m trackcore.experiments run toy
    >>> res = obtain(toy, runs=3, seed=1)  # doctest: +ELLIPSIS
    Note: ... is not at the book's configuration: the book's stored results were not used; computing 3 runs now (to store them: python -m trackcore.experiments run toy --runs 3 --seed 1).
    >>> res.runs, res.from_store
    (3, False)
    """
    experiment = get(name)
    config = experiment.configure(overrides)
    seed = experiment.seed if seed is None else as_int(seed, "seed", minimum=0)
    runs = experiment.runs if runs is None else as_int(runs, "runs", minimum=1)
    if config == experiment.config and seed == experiment.seed:
        path = experiment.default_path()
        check_store(experiment, path, config, seed, 1)  # missing or stale: raise
        stored = read_metadata(path)["runs"]
        if runs > stored:
            res = load(name, runs=stored, seed=seed)
            print(f"Note: {experiment.name} with {runs} runs, not the book's {experiment.runs}: the "
                  f"book's stored results were not used as they stand; runs {stored} to "
                  f"{runs - 1} are computed now and added to the {stored} stored runs (to "
                  f"store them: {experiment.command(runs)}).")
            more, _ = compute_rows(experiment, config, seed, runs,
                                   indices=range(stored, runs), executor=executor)
            cols = {"run": np.arange(runs, dtype=np.int64)}
            for k, v in _columns(more).items():
                cols[k] = np.concatenate([res.columns[k], v])
            meta = dict(res.meta, runs=runs, stored_runs=stored)
            return Results(experiment, meta, cols, path, config)
        res = load(name, runs=runs, seed=seed)
        if runs != experiment.runs:
            print(f"Note: {experiment.name} with {runs} runs, not the book's {experiment.runs}: the "
                  f"book's stored results were not used as they stand "
                  f"(the first {runs} stored runs are).")
        return res
    path = experiment.default_path(config, seed)
    try:
        res = load(name, runs=runs, seed=seed, overrides=overrides, path=path)
        print(f"Note: {experiment.name} is not at the book's configuration: the book's stored results "
              f"were not used; rows read from {path}.")
        return res
    except StaleResultsError:
        pass
    print(f"Note: {experiment.name} is not at the book's configuration: the book's stored results were "
          f"not used; computing {runs} runs now (to store them: "
          f"{experiment.command(runs, seed, _overrides_of(experiment, config))}).")
    return run_experiment(name, runs=runs, seed=seed, overrides=overrides, executor=executor,
                          write=False, progress=False)


# ---------------------------------------------------------------------------- verification
@dataclass(frozen=True)
class Verification:
    """Outcome of :func:`verify_sample`; ``str()`` does not depend on the sample drawn.

    Examples
    --------
    What :func:`verify_sample` returns:

    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> v = verify_sample(run_experiment(toy, runs=20, write=False, progress=False), indices=[0, 5])
    >>> v.checked, v.indices, v.rtol
    (2, (0, 5), 1e-06)
    >>> print(v)
    toy: re-simulated 2 of 20 stored runs (a fresh random sample): all match
    """

    experiment: str
    checked: int
    runs: int
    indices: tuple
    rtol: float
    computed: int = 0

    def __str__(self):
        text = (f"{self.experiment}: re-simulated {self.checked} of {self.runs} stored runs "
                f"(a fresh random sample): all match")
        if self.computed:
            text += f"; {self.computed} more runs were computed now, not read from the store"
        return text


def sample_size(runs, fraction=0.01, minimum=20) -> int:
    """How many runs :func:`verify_sample` checks: ``max(minimum, ceil(fraction * runs))``,
    at most ``runs``.

    Examples
    --------
    At least 20 runs and 1 % of them:

    >>> sample_size(1000), sample_size(5000), sample_size(5)
    (20, 50, 5)
    >>> sample_size(100, fraction=0.0)
    Traceback (most recent call last):
        ...
    ValueError: fraction must be in (0, 1], got 0.0
    """
    runs = as_count(runs, "runs")
    minimum = as_int(minimum, "minimum", minimum=0)
    if not (0.0 < float(fraction) <= 1.0):
        raise ValueError(f"fraction must be in (0, 1], got {fraction!r}")
    return min(runs, max(minimum, math.ceil(float(fraction) * runs - 1e-9)))


def _agree(a, b, rtol):
    """Element-wise: floats equal or within ``rtol`` relative to the stored ``a`` (NaN
    where and only where ``a`` is NaN, infinities equal); anything else equal."""
    if np.issubdtype(a.dtype, np.floating):
        same_nan = np.isnan(a) == np.isnan(b)
        with np.errstate(invalid="ignore"):
            close = (a == b) | (np.abs(a - b) <= rtol * np.abs(a))
        return same_nan & (close | np.isnan(a))
    return a == b


def matches(stored, fresh, rtol=FLOAT_RTOL) -> bool:
    """Whether a recomputed value ``fresh`` reproduces a ``stored`` one by the store's rule
    (the rule of :func:`compare_rows` and :func:`verify_sample`): same shape and dtype,
    integers and booleans equal, floats within relative tolerance ``rtol`` of the stored
    value (default ``FLOAT_RTOL``).  For a notebook's check that a rebuilt run is a stored
    one: the bits may differ on another CPU (numpy's and OpenBLAS's kernels with and
    without AVX-512 round differently), the rule's verdict does not.

    Examples
    --------
    A float within the relative tolerance matches, a larger change does not; integers
    must be equal:

    >>> matches(1.0, 1.0 + 1e-9), matches(1.0, 1.001)
    (True, False)
    >>> matches(np.array([1, 2]), np.array([1, 3]))
    False
    """
    a, b = np.asarray(stored), np.asarray(fresh)
    rtol = float(rtol)
    if not (0.0 <= rtol < 1.0):
        raise ValueError(f"rtol must be in [0, 1), got {rtol!r}")
    return a.shape == b.shape and a.dtype == b.dtype and bool(np.all(_agree(a, b, rtol)))


def compare_rows(stored, fresh, run, rtol=FLOAT_RTOL):
    """Raise :class:`VerificationError` unless ``fresh`` reproduces ``stored``.

    Integer and boolean columns must be equal bit for bit; floating-point columns
    within relative tolerance ``rtol`` element by element (NaN where and only where
    the stored value is NaN, infinities equal).

    Examples
    --------
    >>> compare_rows({"n": np.int64(4), "x": np.float64(2.0)},
    ...              {"n": np.int64(4), "x": np.float64(2.0 + 1e-12)}, run=0)  # passes: None
    >>> compare_rows({"n": np.int64(4)}, {"n": np.int64(5)}, run=0)
    Traceback (most recent call last):
        ...
    trackcore.experiments._core.VerificationError: run 0, column 'n': stored np.int64(4), recomputed np.int64(5) (must be equal)
    """
    if set(stored) != set(fresh):
        raise VerificationError(f"run {run}: columns differ: stored {sorted(stored)}, "
                                f"recomputed {sorted(fresh)}")
    for name in stored:
        a, b = np.asarray(stored[name]), np.asarray(fresh[name])
        if a.shape != b.shape or a.dtype != b.dtype:
            raise VerificationError(f"run {run}, column {name!r}: stored {a.dtype} {a.shape}, "
                                    f"recomputed {b.dtype} {b.shape}")
        ok = _agree(a, b, rtol)
        if not np.all(ok):
            k = np.unravel_index(int(np.argmin(ok)), ok.shape) if ok.ndim else ()
            where = f"[{', '.join(map(str, k))}]" if k else ""
            raise VerificationError(
                f"run {run}, column {name!r}{where}: stored {a[k]!r}, recomputed {b[k]!r}"
                + (f" (relative tolerance {rtol:g})" if np.issubdtype(a.dtype, np.floating)
                   else " (must be equal)"))


def verify_sample(results, *, fraction=0.01, minimum=20, indices=None, executor=None,
                  rtol=FLOAT_RTOL, progress=False) -> Verification:
    """Re-simulate a fresh random sample of stored runs and compare them with the store.

    ``results`` is a :class:`Results` or an experiment name (its book store is loaded).
    The sample, ``sample_size(runs, fraction, minimum)`` distinct runs, is drawn from OS
    entropy (``random.SystemRandom``) at every call, unless ``indices`` are given.
    Raises :class:`VerificationError` naming the run, column, stored and recomputed
    values at the first mismatch; returns a :class:`Verification` whose text is the same
    whichever runs were drawn.

    Examples
    --------
    A fresh random sample of 20 of the 40 runs of a temporary store is re-simulated; its
    text does not depend on the sample:

    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> import tempfile
    >>> tmp = tempfile.TemporaryDirectory()
    >>> res = run_experiment(toy, runs=40, out=Path(tmp.name) / "toy.parquet", progress=False)
    >>> print(verify_sample(res))
    toy: re-simulated 20 of 40 stored runs (a fresh random sample): all match
    >>> tmp.cleanup()
    """
    res = load(results) if isinstance(results, str) else results
    if not isinstance(res, Results):
        raise TypeError(f"results must be a Results or an experiment name, "
                        f"got {type(results).__name__}")
    n = res.runs
    # obtain() may add runs computed now to the stored ones: only stored runs are sampled
    stored = int(res.meta.get("stored_runs", n))
    if indices is None:
        k = sample_size(stored, fraction, minimum)
        indices = sorted(random.SystemRandom().sample(range(stored), k))
    else:
        indices = sorted({as_int(i, "index", minimum=0) for i in indices})
        if any(i >= n for i in indices):
            raise ValueError(f"indices must lie in [0, {n})")
    experiment, config = res.experiment, res.config
    fresh, _ = compute_rows(experiment, config, res.meta["seed"], n, indices=indices,
                            executor=executor, progress=progress)
    for i, row in zip(indices, fresh):
        compare_rows(res.row(i), row, i, rtol)
    return Verification(experiment.name, len(indices), stored, tuple(indices), rtol,
                        n - stored)


# ------------------------------------------------------------------------------- registry
_REGISTRY: dict[str, Experiment] = {}


def register(experiment: Experiment) -> Experiment:
    """Add an experiment to the registry (names are unique).

    Examples
    --------
    Names are unique: the book's experiments are registered when
    :mod:`trackcore.experiments` is imported.

    >>> register(get("hpda-mc-case1"))
    Traceback (most recent call last):
        ...
    ValueError: an experiment named 'hpda-mc-case1' is already registered
    >>> register("hpda-mc-case1")
    Traceback (most recent call last):
        ...
    TypeError: experiment must be an Experiment, got str
    """
    if not isinstance(experiment, Experiment):
        raise TypeError(f"experiment must be an Experiment, got {type(experiment).__name__}")
    if experiment.name in _REGISTRY:
        raise ValueError(f"an experiment named {experiment.name!r} is already registered")
    _REGISTRY[experiment.name] = experiment
    return experiment


def get(name) -> Experiment:
    """The registered experiment ``name``.

    Examples
    --------
    >>> e = get("hpda-mc-case1")
    >>> e.name, e.runs
    ('hpda-mc-case1', 100)
    >>> get("no-such-experiment")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    ValueError: unknown experiment 'no-such-experiment'; registered: ...
    """
    if isinstance(name, Experiment):
        return name
    if not isinstance(name, str):
        raise TypeError(f"name must be a str, got {type(name).__name__}")
    try:
        return _REGISTRY[name]
    except KeyError:
        raise ValueError(f"unknown experiment {name!r}; registered: "
                         f"{', '.join(sorted(_REGISTRY))}") from None


def names() -> list:
    """Names of the registered experiments, in registration order.

    Examples
    --------
    >>> names()[:3]
    ['hpda-mc-case1', 'hpda-mc-case2', 'hpda-mc-case3']
    """
    return list(_REGISTRY)


def status(name) -> str:
    """``current``, ``missing`` or ``stale: <reason>`` for the book store of ``name``.

    Examples
    --------
    A toy experiment has no store under ``results/``:

    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     mean: float = 1.0
    >>> toy = Experiment("toy", "one normal draw", trial=lambda rng, mean: rng.normal(mean),
    ...                  call=lambda c: ((), {"mean": c.mean}), extract=lambda r, c: {"x": r},
    ...                  config=Toy(), seed=7, runs=20, version="1")
    >>> status(toy)
    'missing'
    """
    e = get(name)
    try:
        check_store(e, e.default_path(), e.config, e.seed, e.runs)
    except MissingResultsError:
        return "missing"
    except StaleResultsError as exc:
        return "stale: " + str(exc).split(" are stale: ")[-1].split("\n")[0]
    except Exception as exc:  # unreadable file
        return f"unreadable: {exc}"
    return "current"


def book_check(ok, message, *, book) -> None:
    """A check of the book's own results, as the notebooks make it.

    On the book's runs (``book`` true) a failed check raises ``AssertionError(message)``, so
    that ``pytest --nbval`` fails; on any other configuration (a reader who changed a
    parameter, a run count or a seed) it prints a note naming the check instead, so the
    notebook runs to the end and says which of the book's statements no longer hold.
    Returns nothing, so a cell that ends with a check displays nothing.

    Examples
    --------
    >>> from trackcore.experiments import book_check
    >>> book_check(2 + 2 == 4, "arithmetic holds", book=True)
    >>> book_check(False, "the 5 % target is met", book=False)
    Note: not the book's runs, and the book's check fails here: the 5 % target is met
    """
    if not isinstance(message, str):
        raise TypeError(f"message must be a str, got {type(message).__name__}")
    if ok:
        return
    if book:
        raise AssertionError(message)
    print(f"Note: not the book's runs, and the book's check fails here: {message}")
