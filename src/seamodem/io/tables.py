"""The column schema of the tables seamodem writes, and reading them with pandas or polars with stable types.

Every table (``rx``'s measurement files in every mode, CSV or JSON Lines;
``nav track``'s track and frame files; ``nav simulate``'s table) has one
header row of named columns. Each column has one type, whatever the file's
format or the receiver's mode:

=========  ================================  ======================  ==============
type       written (CSV / JSON Lines)        pandas dtype            polars dtype
=========  ================================  ======================  ==============
``int``    ``3`` / ``3``                     ``int64``               ``Int64``
``float``  ``0.25`` / ``0.25``               ``float64``             ``Float64``
``bool``   ``true``, ``false`` / JSON bools  ``boolean``             ``Boolean``
``str``    text, quoted when it needs it     ``str``/``object``      ``String``
=========  ================================  ======================  ==============

One null token: a missing value (a number not measured, a frame not decoded)
is an empty CSV cell or a JSON ``null``; empty text is empty text, never null.
A file's default read can still guess wrongly when a column holds only nulls
(pandas: float64 for an all-empty text column; polars: String for an all-empty
number column), so :func:`read_table` passes the schema to the library.
The schema is also in a measurement file's sidecar (``schema``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

__all__ = ["NULL_TOKEN", "UNITS", "column_type", "unit_of", "table_schema", "csv_cell", "read_table",
           "pandas_options", "polars_options"]

#: the one null token of a CSV cell (JSON Lines: ``null``)
NULL_TOKEN = ""
#: a column name's suffix → its unit (SPEC §1: names carry the unit)
UNITS = {"_s": "s", "_m": "m", "_mps": "m/s", "_mps2": "m/s²", "_m2": "m²", "_db": "dB", "_dbhz": "dB-Hz",
         "_rad": "rad", "_deg": "deg", "_rad_s": "rad/s", "_hz": "Hz", "_pct": "%", "_m2s": "m²/s"}
#: columns of seamodem's other tables whose type the name's unit does not give
_NAMED = {"frame_index": "int", "outliers": "int", "diverged": "int", "runs": "int", "status": "str",
          "bearing_status": "str", "filter": "str", "nis": "float"}


def unit_of(name: str) -> str:
    """The unit a column's name carries (SPEC §1), ``""`` for a count, a ratio or text."""
    for suffix in sorted(UNITS, key=len, reverse=True):
        if name.endswith(suffix):
            return UNITS[suffix]
    return ""


def column_type(name: str, annotation: str | None = None) -> str | None:
    """``int``, ``float``, ``bool`` or ``str`` of a column: from a record field's annotation, else its name.

    Returns None for a column neither gives (the library's guess is kept).
    """
    if annotation is not None:
        for kind in ("bool", "int", "float", "str"):
            if annotation.startswith(kind):
                return kind
    return _NAMED.get(name) or ("float" if unit_of(name) else None)


def table_schema(names, annotations: dict[str, str] | None = None) -> list[dict[str, str]]:
    """The schema of a table's columns: ``[{"name", "type", "unit"}, ...]`` (type None when unknown)."""
    annotations = annotations or {}
    return [{"name": n, "type": column_type(n, annotations.get(n)), "unit": unit_of(n)} for n in names]


def csv_cell(value):
    """A value as a CSV cell: None and NaN → the null token, bools → true/false, floats → shortest repr."""
    if value is None:
        return NULL_TOKEN
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return NULL_TOKEN if math.isnan(value) else repr(value)
    return value


def _schema_of(path: Path, schema) -> list[dict]:
    if schema is not None:
        return schema
    sidecar = path.with_name(path.name + ".json")
    if sidecar.is_file():
        meta = json.loads(sidecar.read_text(encoding="utf-8"))
        if isinstance(meta, dict) and isinstance(meta.get("schema"), dict):
            return meta["schema"]["columns"]
    if path.suffix.lower() == ".jsonl":
        with path.open(encoding="utf-8") as f:
            names = list(json.loads(f.readline() or "{}"))
    else:
        import csv

        with path.open(encoding="utf-8-sig", newline="") as f:
            names = next(csv.reader(f), [])
    return table_schema(names)


_PANDAS = {"int": "int64", "float": "float64", "bool": "boolean", "str": "str"}
_POLARS = {"int": "Int64", "float": "Float64", "bool": "Boolean", "str": "String"}


def pandas_options(schema: list[dict], *, jsonl: bool = False) -> dict:
    """Keyword arguments of ``pandas.read_csv`` (or ``read_json(lines=True)``) that give the schema's dtypes."""
    dtypes = {c["name"]: _PANDAS[c["type"]] for c in schema if c.get("type")}
    if jsonl:
        return {"lines": True, "dtype": dtypes}
    # text keeps its empty cells as "" (no NA); every other column reads the empty cell as missing
    na = {c["name"]: [NULL_TOKEN] for c in schema if c.get("type") != "str"}
    return {"dtype": dtypes, "keep_default_na": False, "na_values": na}


def polars_options(schema: list[dict], *, jsonl: bool = False) -> dict:
    """Keyword arguments of ``polars.read_csv`` (or ``read_ndjson``) that give the schema's dtypes."""
    import polars as pl

    dtypes = {c["name"]: getattr(pl, _POLARS[c["type"]]) for c in schema if c.get("type")}
    if jsonl:
        return {"schema_overrides": dtypes}
    return {"schema_overrides": dtypes, "empty_string_is_null": False}


def read_table(path, *, library: str = "pandas", schema: list[dict] | None = None):
    """Read a table seamodem wrote (CSV or JSON Lines) as a DataFrame with the schema's dtypes.

    Parameters
    ----------
    path : str or Path
        A ``.csv`` or ``.jsonl`` table.
    library : {"pandas", "polars"}
        Which DataFrame to return.
    schema : list of dict, optional
        ``[{"name", "type", "unit"}, ...]``; default: the sidecar's ``schema``
        (measurement files), else :func:`table_schema` of the header's names.

    Returns
    -------
    pandas.DataFrame or polars.DataFrame
        ``int`` → int64 / Int64, ``float`` → float64 / Float64 (missing: NaN /
        null), ``bool`` → boolean / Boolean (missing: <NA> / null), ``str`` →
        str / String (empty stays ``""``).

    Examples
    --------
    >>> from seamodem.io.tables import read_table
    >>> df = read_table("meas.csv")                      # doctest: +SKIP
    >>> df = read_table("meas.jsonl", library="polars")  # doctest: +SKIP
    """
    path = Path(path)
    jsonl = path.suffix.lower() == ".jsonl"
    columns = _schema_of(path, schema)
    if library == "pandas":
        import pandas as pd

        return (pd.read_json if jsonl else pd.read_csv)(path, **pandas_options(columns, jsonl=jsonl))
    if library == "polars":
        import polars as pl

        return (pl.read_ndjson if jsonl else pl.read_csv)(path, **polars_options(columns, jsonl=jsonl))
    raise ValueError(f"library must be 'pandas' or 'polars', got {library!r}")
