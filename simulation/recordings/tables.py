"""Dataset table files (Parquet with project metadata, CSV), written atomically.

A file is first written to a temporary directory beside its destination and then renamed onto
it, so a failed write never leaves a partial file behind. Parquet files carry a JSON metadata
block (format version, arm, units...) under ``METADATA_KEY``; a file without it, or of another
format version, is refused with ``TableFormatError``.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

TABLE_FORMAT_VERSION = 1
METADATA_KEY = b"raven_calibration.dataset"


class TableFormatError(ValueError):
    """A table file that is not a readable calibration dataset of the supported format version."""


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, *, overwrite: bool) -> Iterator[Path]:
    """Yield a temporary path to write; on success it is renamed onto ``path``.

    Parameters
    ----------
    path : path-like
        The destination file; its directory must exist.
    overwrite : bool
        Whether an existing destination may be replaced.

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is False.
    FileNotFoundError
        The destination directory does not exist.
    """
    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists already (pass overwrite=True to replace it)")
    if not path.parent.is_dir():
        raise FileNotFoundError(f"directory {path.parent} does not exist")
    workdir = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
    try:
        temporary = workdir / path.name
        yield temporary
        if not temporary.is_file():
            raise RuntimeError(f"nothing was written for {path}")
        os.replace(temporary, path)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


def write_parquet(frame: pd.DataFrame, path: str | os.PathLike, metadata: Mapping[str, object],
                  *, overwrite: bool = True) -> Path:
    """Write ``frame`` to a Parquet file with ``metadata`` (JSON) and the format version.

    Parameters
    ----------
    frame : DataFrame
        The table; its index is not stored.
    path : path-like
        Destination file.
    metadata : mapping
        JSON-serializable description of the table (units, arm...); ``format_version`` is added.
    overwrite : bool
        Whether an existing file may be replaced.

    Returns
    -------
    Path
        The written file.
    """
    document = {**metadata, "format_version": TABLE_FORMAT_VERSION}
    table = pa.Table.from_pandas(frame, preserve_index=False)
    schema_metadata = dict(table.schema.metadata or {})
    schema_metadata[METADATA_KEY] = json.dumps(document, sort_keys=True).encode()
    table = table.replace_schema_metadata(schema_metadata)
    with atomic_output(path, overwrite=overwrite) as temporary:
        pq.write_table(table, temporary)
    return Path(path)


def read_parquet(path: str | os.PathLike) -> tuple[pd.DataFrame, dict]:
    """Read a table written by ``write_parquet``.

    Returns
    -------
    frame : DataFrame
    metadata : dict
        The JSON metadata block, including ``format_version``.

    Raises
    ------
    FileNotFoundError
        No such file.
    TableFormatError
        Not a Parquet file, no project metadata, or another format version.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no dataset file {path}")
    try:
        table = pq.read_table(path)
    except (pa.ArrowException, OSError) as error:
        raise TableFormatError(f"{path}: not a readable Parquet file ({error})") from error
    raw = (table.schema.metadata or {}).get(METADATA_KEY)
    if raw is None:
        raise TableFormatError(f"{path}: no {METADATA_KEY.decode()} metadata; not a calibration dataset file")
    try:
        metadata = json.loads(raw)
    except json.JSONDecodeError as error:
        raise TableFormatError(f"{path}: unreadable dataset metadata ({error})") from error
    version = metadata.get("format_version")
    if version != TABLE_FORMAT_VERSION:
        raise TableFormatError(
            f"{path}: dataset format version {version!r}, this reader supports version {TABLE_FORMAT_VERSION}"
        )
    return table.to_pandas(), metadata


def read_csv(path: str | os.PathLike) -> pd.DataFrame:
    """Read a table written by ``write_csv``.

    Raises
    ------
    FileNotFoundError
        No such file.
    TableFormatError
        Not a readable CSV table (empty, binary, malformed).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no dataset file {path}")
    try:
        return pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, ValueError) as error:
        raise TableFormatError(f"{path}: not a readable CSV table ({error})") from error


def write_csv(frame: pd.DataFrame, path: str | os.PathLike, *, overwrite: bool = True) -> Path:
    """Write ``frame`` as CSV (header row, no index, floats at full precision), atomically."""
    with atomic_output(path, overwrite=overwrite) as temporary:
        frame.to_csv(temporary, index=False)
    return Path(path)
