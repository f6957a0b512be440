"""TOML text or plain tables -> :class:`~afferent.scene.schema.Scene`: unit-suffixed keys to SI, types checked.

Every error names the table, the key as written and its line (:class:`SceneError`).
"""

from __future__ import annotations

from .._typing import PathLike

import math
import os
import tomllib
from dataclasses import dataclass, fields
from decimal import Decimal
from pathlib import Path

from .._validation import suggest
from .defaults import resolve
from .schema import _QUANTITIES, _TABLES, Scene, SceneError, SceneTypeError, _Origin, key_lines

# ---------------------------------------------------------------------------- parsing
def _keys_of(cls) -> dict[str, tuple]:
    """Accepted key -> (dataclass field, power of ten to SI or None)."""
    out = {}
    for f in fields(cls):
        q = f.metadata.get("quantity")
        if q:
            si, units = _QUANTITIES[q]
            base = f.name[: -len(si) - 1]
            for suffix, exp in units.items():
                out[f"{base}_{suffix}"] = (f, exp)
        else:
            out[f.name] = (f, None)
        for alias in f.metadata.get("aliases", ()):
            out[alias] = (f, None)
    return out


_CONVERTIBLE = {"length": "LENGTH_UNITS", "time": "TIME_UNITS"}  # quantities afferent.units can convert


def key_hint(key: str, value: object, keys: dict) -> str:
    """``" Did you mean ...?"`` for an unknown ``key`` among ``keys`` (:func:`_keys_of`) that keeps its meaning.

    A suggestion is never a key of another unit than the one written: a key ending in a unit suffix of its
    quantity gets the key of that unit; one ending in another unit afferent knows (``d_ref_cm``) gets the
    key of a suffix with ``value`` converted (``d_ref_mm = 5``); one without a unit (``d_ref = 0.5``) gets
    the keys of every unit, saying what the number would then mean. ``value`` None: no example value.
    """
    from .. import units

    hint = suggest(key, list(keys))
    if not hint:
        return hint
    match = hint[len(" Did you mean '"):-len("'?")]
    f, _ = keys[match]
    q = f.metadata.get("quantity")
    if not q:
        return hint
    si, suffixes = _QUANTITIES[q]
    base = f.name[: -len(si) - 1]
    own = [u for u in suffixes if key.endswith("_" + u)]
    if own:
        return f" Did you mean '{base}_{max(own, key=len)}'?"
    stem, _, unit = key.rpartition("_")
    table = getattr(units, _CONVERTIBLE.get(q, ""), {})
    if stem and unit in table and _is_number(value):  # another unit: the value converted to the nearest suffix
        si_value = value * table[unit]
        near = min(suffixes, key=lambda u: abs(math.log10(abs(si_value) / 10.0 ** suffixes[u])) if si_value else 0)
        return f" Did you mean {base}_{near} = {_scale(si_value, -suffixes[near]):.6g} ({value:g} {unit})?"
    said = f"{value:g}" if _is_number(value) else "X"
    first, second = sorted(suffixes, key=lambda u: (u not in ("mm", "ms", "mm_per_s", "hz"), u))[:2]

    def word(u):
        return {"hz": "Hz", "khz": "kHz"}.get(u, u.replace("_per_", "/"))

    return (f" {key!r} is a {q}, whose key names the unit, one of {', '.join(f'{base}_{u}' for u in suffixes)}: "
            f"{base}_{first} = {said} is {said} {word(first)}, {base}_{second} = {said} is {said} {word(second)}.")


def _known_keys_text(cls) -> str:
    parts = []
    for f in fields(cls):
        q = f.metadata.get("quantity")
        if q:
            si, units = _QUANTITIES[q]
            parts.append(f"{f.name[: -len(si) - 1]}_<{'|'.join(units)}>")
        else:
            parts.append(f.name)
    return ", ".join(parts)


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _scale(v, exp):
    """``v * 10**exp`` as an exact decimal shift (0.68 mm -> 0.00068 m, the float nearest 0.68e-3)."""
    if exp in (None, 0):
        return float(v)
    return float(Decimal(repr(float(v))).scaleb(exp))


def _type_name(v) -> str:
    return {"str": "a string", "int": "an integer", "float": "a number", "bool": "a boolean", "list": "an array",
            "dict": "a table"}.get(type(v).__name__, type(v).__name__)


@dataclass(frozen=True)
class _Given:
    """One key's value as written, with what its messages need."""

    value: object
    unit: str  # ' in ms' for a key with a unit suffix, else ''
    origin: _Origin
    table: str
    key: str

    def bad_type(self, expect):
        return self.origin.error(self.table, self.key, f"[{self.table}] {self.key!r} must be {expect}; got "
                                 f"{self.value!r} ({_type_name(self.value)}) instead.", cls=SceneTypeError)

    def bad_value(self, expect, hint=""):
        return self.origin.error(self.table, self.key,
                                 f"[{self.table}] {self.key!r} must be {expect}; got {self.value!r} instead.{hint}")

    def finite(self, v):
        if isinstance(v, float) and not math.isfinite(v):
            raise self.bad_value(f"a finite number{self.unit}")
        return v

    def path(self, v):
        p = Path(os.path.expanduser(v))
        return os.path.normpath(str(p if p.is_absolute() else Path(self.origin.base_dir) / p))


def _convert(value, f, exp, *, origin: _Origin, table: str, key: str):
    """A key's value checked against its schema field ``f`` and converted to SI (``exp``: power of ten)."""
    md = f.metadata
    kind, choices = md["kind"], md["choices"]
    q = md.get("quantity")
    unit = ""
    if q:  # the unit as written in the key: 'dt_ms' -> ' in ms'
        written = max((u for u in _QUANTITIES[q][1] if key.endswith("_" + u)), key=len)
        unit = f" in {written.replace('_per_', '/')}"
    c = _Given(value, unit, origin, table, key)
    if kind in ("str", "choice", "bool", "int", "number", "path", "side"):
        return _convert_scalar(c, kind, choices, exp)
    return _convert_array(c, f, kind, choices, exp)


def _convert_scalar(c: _Given, kind: str, choices: tuple, exp):
    """A string, choice, boolean, integer, number (to SI) or path (against the scene's folder)."""
    if kind in ("str", "choice"):
        if not isinstance(c.value, str):
            raise c.bad_type("a string" + (f", one of {', '.join(map(repr, choices))}" if choices else ""))
        if kind == "choice" and c.value not in choices:
            raise c.bad_value(f"one of {', '.join(map(repr, choices))}", suggest(c.value, choices))
        return c.value
    if kind == "bool":
        if not isinstance(c.value, bool):
            raise c.bad_type("true or false")
        return c.value
    if kind == "int":
        if not isinstance(c.value, int) or isinstance(c.value, bool):
            raise c.bad_type("an integer")
        return c.value
    if kind == "number":
        if not _is_number(c.value):
            raise c.bad_type(f"a number{c.unit}")
        return _scale(c.finite(c.value), exp)
    if kind == "side":
        if c.value != "average" and (not isinstance(c.value, int) or isinstance(c.value, bool)):
            raise c.bad_type("'average' or a material id (an integer)")
        return c.value
    if kind == "path":
        if not isinstance(c.value, str) or not c.value:
            raise c.bad_type("a path (a non-empty string)")
        return c.path(c.value)
    raise AssertionError(kind)  # pragma: no cover - schema bug


def _convert_array(c: _Given, f, kind: str, choices: tuple, exp):
    """Paths, strings, outputs, numbers (to SI), a [min, max] pair or integers, as tuples."""
    if kind == "paths":
        items = [c.value] if isinstance(c.value, str) else c.value
        if not isinstance(items, list) or not items or not all(isinstance(v, str) and v for v in items):
            raise c.bad_type("a path or a non-empty array of paths")
        return tuple(c.path(v) for v in items)
    if kind in ("strs", "outputs"):
        if not isinstance(c.value, list) or not all(isinstance(v, str) for v in c.value):
            raise c.bad_type("an array of strings")
        if kind == "outputs":
            for v in c.value:
                if v not in choices:
                    raise c.origin.error(c.table, c.key, f"[{c.table}] {c.key!r} must list outputs among "
                                         f"{', '.join(map(repr, choices))}; got {v!r} instead.{suggest(v, choices)}")
            if not c.value:
                raise c.bad_value(f"a non-empty array of outputs among {', '.join(map(repr, choices))}")
            return tuple(dict.fromkeys(c.value))
        return tuple(c.value)
    if kind == "str_or_strs":
        if isinstance(c.value, str):
            return c.value
        if not isinstance(c.value, list) or not c.value or not all(isinstance(v, str) for v in c.value):
            raise c.bad_type("a string or an array of strings")
        return tuple(c.value)
    if kind == "numbers":
        if not isinstance(c.value, list) or not all(_is_number(v) for v in c.value):
            raise c.bad_type(f"an array of numbers{c.unit}")
        return tuple(_scale(c.finite(v), exp) for v in c.value)
    if kind == "pair":
        if not isinstance(c.value, list) or len(c.value) != 2 or not all(_is_number(v) for v in c.value):
            raise c.bad_type(f"a pair [min, max] of numbers{c.unit}")
        lo, hi = (_scale(c.finite(v), exp) for v in c.value)
        if lo > hi and f.name != "origin_m":
            raise c.bad_value(f"a pair [min, max]{c.unit} with min <= max")
        return (lo, hi)
    if kind == "int_or_ints":
        ok = (isinstance(c.value, int) and not isinstance(c.value, bool)) or (
            isinstance(c.value, list) and c.value and all(isinstance(v, int) and not isinstance(v, bool) for v in c.value))
        if not ok:
            raise c.bad_type("an integer or an array of integers")
        return c.value if isinstance(c.value, int) else tuple(c.value)
    raise AssertionError(kind)  # pragma: no cover - schema bug


def _parse_table(cls, data: dict, *, origin: _Origin, table: str):
    keys = _keys_of(cls)
    values, given_as = {}, {}
    for key, value in data.items():
        if key not in keys:
            hint = key_hint(key, value, keys)
            raise origin.error(table, key, f"unknown key {key!r} in [{table}]; known keys are {_known_keys_text(cls)}.{hint}")
        f, exp = keys[key]
        if f.name in values:
            raise origin.error(table, key, f"[{table}] {key!r} and {given_as[f.name]!r} give the same setting; keep one.")
        values[f.name] = _convert(value, f, exp, origin=origin, table=table, key=key)
        given_as[f.name] = key
    return cls(**values), given_as


def scene_from_dict(data: dict, *, base_dir: PathLike | None=None, source: PathLike | None=None, _lines: dict | None=None) -> Scene:
    """Build a :class:`Scene` from tables (as :func:`tomllib.loads` or :meth:`Scene.to_dict` give them).

    Parameters
    ----------
    data : dict
        ``{'export': {...}, 'receptors': {...}, ...}``; ``None`` values count as not given.
    base_dir : str or path-like, optional
        Folder that relative paths are resolved against; default the current folder.
    source : str, optional
        The scene file, for messages.

    Returns
    -------
    Scene
        Not yet resolved (see :func:`resolve`).

    Raises
    ------
    SceneError, SceneTypeError
        Unknown table or key; a value of the wrong type or out of its choices.
    """
    origin = _Origin(None if source is None else os.fspath(source), os.path.abspath(os.fspath(base_dir or os.getcwd())),
                     dict(_lines or {}))
    if not isinstance(data, dict):
        raise SceneTypeError(f"A scene must be a table of tables; got {_type_name(data)} instead.")
    sections, given = {}, {}
    for table, value in data.items():
        if table not in _TABLES:
            if isinstance(value, dict):
                hint = suggest(table, list(_TABLES))
                raise origin.error(table, None, f"unknown table [{table}]; known tables are "
                                   f"{', '.join(f'[{t}]' for t in _TABLES)}.{hint}")
            hint = suggest(table, list(_TABLES))
            raise origin.error(None, table, f"unknown key {table!r} outside any table; a scene holds only the tables "
                               f"{', '.join(f'[{t}]' for t in _TABLES)}.{hint}")
        if not isinstance(value, dict):
            raise origin.error(None, table, f"{table!r} must be a table ([{table}]); got {value!r} "
                               f"({_type_name(value)}) instead.", cls=SceneTypeError)
        attr, cls = _TABLES[table]
        clean = {k: v for k, v in value.items() if v is not None}
        sections[attr], given[table] = _parse_table(cls, clean, origin=origin, table=table)
    origin.given.update(given)
    return Scene(**sections, source=origin.path, origin=origin)


def read_toml_text(path: str, what: str) -> str:
    """The text of a TOML file (scene or sweep), or an error naming ``what`` and the file.

    Raises FileNotFoundError when it does not exist, :class:`SceneError` when it is not UTF-8.
    """
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{what} {path!r} not found.")
    with open(path, "rb") as f:
        raw = f.read()
    try:
        return raw.decode("utf-8-sig")  # a byte-order mark (Windows editors write one) is not part of the text
    except UnicodeDecodeError as err:
        raise SceneError(f"{what} {path!r} must be UTF-8 text (TOML); it is not: {err}.", path=path) from err


def loads_toml(text: str, where: str, path: PathLike | None=None) -> dict:
    """The tables of TOML text (scene or sweep), or a :class:`SceneError` starting with ``where``.

    A leading byte-order mark is dropped; nesting too deep for the parser (arrays or inline
    tables nested hundreds of levels, which :mod:`tomllib` meets with a ``RecursionError``) is
    an error of the file, not of afferent.
    """
    try:
        return tomllib.loads(text.removeprefix("\ufeff"))
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"{where} is not valid TOML: {err}.", path=path) from err
    except RecursionError:
        raise SceneError(f"{where} nests arrays or inline tables too deeply to be read; a scene needs at most "
                         "a list of lists.", path=path) from None


def parse_scene(text: str, *, base_dir: PathLike | None=None, source: PathLike | None=None) -> Scene:
    """Parse a scene from TOML text (relative paths against ``base_dir``); see :func:`load_scene`."""
    where = f"Scene file {os.fspath(source)!r}" if source else "Scene"
    data = loads_toml(text, where, source)
    return scene_from_dict(data, base_dir=base_dir, source=source, _lines=key_lines(text))


def load_scene(path: PathLike, *, resolve_defaults: bool = True) -> Scene:
    """Read a scene file (TOML, read with :mod:`tomllib`).

    Parameters
    ----------
    path : str or path-like
        The ``.toml`` file. Relative paths inside it are resolved against its folder.
    resolve_defaults : bool, default=True
        Fill defaults and check requirements (:func:`resolve`); False returns the scene as written.

    Returns
    -------
    Scene

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    SceneError, SceneTypeError
        Invalid TOML; an unknown table or key, a wrong type or a bad value (the message names
        the key and its line); a requirement missing (e.g. ``[export] file``).

    Examples
    --------
    >>> scene = load_scene("sample_sed/scenes/sed_map.toml")  # doctest: +SKIP
    >>> plan(scene)  # doctest: +SKIP
    ['reading', 'sampling']
    """
    path = os.path.abspath(os.fspath(path))
    text = read_toml_text(path, "Scene file")
    scene = parse_scene(text, base_dir=os.path.dirname(path), source=path)
    return resolve(scene) if resolve_defaults else scene

