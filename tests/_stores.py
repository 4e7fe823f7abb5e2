"""A corrupted copy of a stored experiment, for the tests that check that the sampled
verification catches a changed row."""
import shutil

import pyarrow as pa
import pyarrow.parquet as pq

from trackcore.experiments import get, load


def corrupted_store(name, tmp_path, column, run, delta=1):
    """Experiment ``name``'s book store copied into ``tmp_path`` with ``delta`` added to
    ``column`` at run ``run``; returns the copy loaded as :class:`Results`."""
    path = get(name).default_path()
    bad = tmp_path / "bad.parquet"
    shutil.copy(path, bad)
    table = pq.read_table(path)
    values = table.column(column).to_numpy().copy()
    values[run] += delta
    i = table.schema.get_field_index(column)
    pq.write_table(table.set_column(i, table.schema.field(i), pa.array(values)), bad)
    return load(name, path=bad)
