"""The parameter set of a virtual RAVEN-II arm: hardware constants plus named effects.

A parameter set can be written to and read from JSON (:meth:`RavenParameters.to_dict`,
:meth:`RavenParameters.from_dict`, :meth:`RavenParameters.to_json`, :meth:`RavenParameters.from_json`),
so a robot described by its own identified values can replace the virtual RAVEN-II's defaults.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import os
import tempfile
from dataclasses import dataclass, field
from numbers import Integral, Real
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from simulation.model.constants import RavenConstants
from simulation.model.effects import EFFECT_NAMES, EFFECT_TYPES, Effect, effect_type


@functools.lru_cache(maxsize=None)
def _switched_off(name: str) -> Effect:
    """The effect ``name`` switched off, with its defaults: one shared object per name (effects are
    frozen and their arrays read-only), so asking a parameter set for an effect it lacks costs no
    construction (the discrepancy replay asks a dozen times per replay)."""
    return effect_type(name)(enabled=False)


def _default_effects() -> tuple[Effect, ...]:
    return tuple(t() for t in EFFECT_TYPES)


_KEYS = ("arm", "constants", "effects", "gravity")
"""Top-level keys of a parameter dictionary, one per field of :class:`RavenParameters`."""


def _jsonable(value: Any) -> Any:
    """A field value as JSON-ready Python: arrays and tuples as lists of floats, numbers as floats."""
    if isinstance(value, (bool, str)) or value is None:
        return value
    if isinstance(value, (np.ndarray, tuple, list)):
        return [float(v) for v in np.asarray(value, dtype=float).ravel()]
    if isinstance(value, Integral):
        return int(value)
    return float(value)


def _fields_dict(obj: Any) -> dict[str, Any]:
    """The init fields of a dataclass instance, keyed by field name, as JSON-ready values."""
    return {f.name: _jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj) if f.init}


def _number(label: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, Real):
        raise ValueError(f"{label} must be a number, got {type(value).__name__} {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"{label} must be finite, got {value!r}")
    return float(value)


def _field_value(label: str, default: Any, value: Any) -> Any:
    """Check a JSON value against the kind and size of the field's default; return it typed."""
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ValueError(f"{label} must be true or false, got {type(value).__name__} {value!r}")
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ValueError(f"{label} must be a string, got {type(value).__name__} {value!r}")
        return value
    if isinstance(default, (np.ndarray, tuple)):
        size = np.size(default)
        if not isinstance(value, (list, tuple)):
            raise ValueError(f"{label} must be a list of {size} numbers, got {type(value).__name__} {value!r}")
        if len(value) != size:
            raise ValueError(f"{label} must be a list of {size} numbers, got {len(value)}")
        numbers = [_number(f"{label}[{i}]", v) for i, v in enumerate(value)]
        return tuple(numbers) if isinstance(default, tuple) else np.array(numbers)
    if isinstance(default, Integral):
        number = _number(label, value)
        if number != int(number):
            raise ValueError(f"{label} must be a whole number, got {value!r}")
        return int(number)
    if isinstance(default, Real):
        return _number(label, value)
    raise TypeError(f"{label}: fields of type {type(default).__name__} cannot be read from a dictionary")


def _from_fields(label: str, default: Any, given: Any) -> Any:
    """``default`` with the fields named in ``given`` replaced, each checked; clear one-line errors."""
    if not isinstance(given, Mapping):
        raise ValueError(f"{label} must be an object of fields, got {type(given).__name__} {given!r}")
    names = [f.name for f in dataclasses.fields(default) if f.init]
    for key in given:
        if key not in names:
            raise ValueError(f"{label}: unknown field {key!r}; known fields: {', '.join(names)}")
    changes = {key: _field_value(f"{label}.{key}", getattr(default, key), value) for key, value in given.items()}
    try:
        return dataclasses.replace(default, **changes)
    except (ValueError, TypeError) as error:
        # numpy may wrap a long array over lines in the message; keep it to one line.
        raise ValueError(f"{label}: {' '.join(str(error).split())}") from None


def _frozen(value: Any) -> Any:
    """A hashable image of a JSON-ready value (dicts as sorted item tuples, lists as tuples)."""
    if isinstance(value, dict):
        return tuple(sorted((k, _frozen(v)) for k, v in value.items()))
    if isinstance(value, list):
        return tuple(_frozen(v) for v in value)
    return value


def _reject_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    keys = [k for k, _ in pairs]
    for key in keys:
        if keys.count(key) > 1:
            raise ValueError(f"key {key!r} appears twice in one object")
    return dict(pairs)


def _dumps(value: Any, indent: int = 0) -> str:
    """JSON text with one object key per line and every list on one line (readable, still plain JSON)."""
    if not isinstance(value, dict) or not value:
        return json.dumps(value, allow_nan=False)
    pad = "  " * (indent + 1)
    items = [f"{pad}{json.dumps(k)}: {_dumps(v, indent + 1)}" for k, v in value.items()]
    return "{\n" + ",\n".join(items) + "\n" + "  " * indent + "}"


@dataclass(frozen=True)
class RavenParameters:
    """Immutable description of one simulated RAVEN-II arm.

    Attributes
    ----------
    arm : "left" (gold) or "right" (green).
    constants : hardware and controller constants (:class:`~simulation.model.constants.RavenConstants`).
    effects : one object per effect of :data:`simulation.model.effects.EFFECT_NAMES`, each with its own
        on/off switch. Effects missing from the tuple are taken as switched off.
    gravity : (3,) gravity vector in the arm's base frame (m/s^2), or None for the kinematics
        model's documented default.

    Notes
    -----
    ``==`` compares two parameter sets by their :meth:`to_dict` images, so every array element
    exactly (no tolerance); an effect left out of ``effects`` equals that effect switched off with
    its defaults, since the simulator treats both alike. Parameter sets are hashable, consistently
    with ``==``. (The effect and constants objects themselves hold numpy arrays, and ``==`` between
    two distinct ones raises numpy's ambiguous-truth-value error: compare parameter sets instead.)
    """

    arm: str = "left"
    constants: RavenConstants | None = None
    effects: tuple[Effect, ...] = field(default_factory=_default_effects)
    gravity: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if self.arm not in ("left", "right"):
            raise ValueError(f"arm must be 'left' or 'right', got {self.arm!r}")
        if self.constants is None:
            object.__setattr__(self, "constants", RavenConstants(arm=self.arm))
        elif self.constants.arm != self.arm:
            raise ValueError(f"constants are for the {self.constants.arm} arm, parameters for the {self.arm} arm")
        effects = tuple(self.effects)
        seen: set[str] = set()
        for effect in effects:
            if not isinstance(effect, Effect):
                raise TypeError(f"effects must be Effect objects, got {type(effect).__name__}")
            if effect.name in seen:
                raise ValueError(f"effect {effect.name!r} appears twice")
            seen.add(effect.name)
        object.__setattr__(self, "effects", effects)
        if self.gravity is not None:
            g = np.asarray(self.gravity, dtype=float)
            if g.shape != (3,) or not np.all(np.isfinite(g)):
                raise ValueError(f"gravity must be a finite 3-vector, got {self.gravity!r}")
            object.__setattr__(self, "gravity", tuple(float(v) for v in g))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RavenParameters):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        return hash(_frozen(self.to_dict()))

    def to_dict(self) -> dict[str, Any]:
        """The parameter set as a JSON-ready dictionary, readable back by :meth:`from_dict`.

        Returns
        -------
        dict
            ``{"arm": "left", "constants": {...}, "effects": {...}, "gravity": [...] or None}``.
            ``constants`` holds every field of :class:`~simulation.model.constants.RavenConstants`
            by field name (its ``arm`` too). ``effects`` holds every effect of
            :data:`~simulation.model.effects.EFFECT_NAMES` by name, each as ``{"enabled": bool,
            <field>: value, ...}`` with the effect's own field names (an effect left out of
            ``effects`` appears switched off with its defaults). Arrays and tuples are lists of
            floats, scalars are numbers, all in the SI units of the fields' documentation. Python's
            ``json`` writes each float as its shortest round-tripping repr, so
            ``from_dict(json.loads(json.dumps(p.to_dict()))) == p`` exactly.
        """
        return {
            "arm": self.arm,
            "constants": _fields_dict(self.constants),
            "effects": {name: _fields_dict(self.effect(name)) for name in EFFECT_NAMES},
            "gravity": _jsonable(self.gravity),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "RavenParameters":
        """A parameter set from a dictionary shaped as :meth:`to_dict` writes it.

        A partial dictionary describes only what differs from the virtual RAVEN-II: a missing
        ``arm`` is "left", missing ``constants`` fields take the defaults of
        :class:`~simulation.model.constants.RavenConstants` for that arm, a missing effect is the
        effect with its defaults (switched on, as in ``RavenParameters()``), a missing field of an
        effect takes that effect's default (``enabled`` included), and a missing ``gravity`` is None
        (the kinematics model's default).

        Parameters
        ----------
        data : mapping
            ``{"arm": "left" | "right", "constants": {field: value}, "effects": {effect name:
            {"enabled": bool, field: value}}, "gravity": [gx, gy, gz] | None}``, all keys optional.
            Array fields are lists of exactly the field's length, scalar fields numbers, SI units.

        Raises
        ------
        ValueError
            One line naming the key, effect and field at fault: an unknown top-level key, an
            unknown effect or field, a list of the wrong length, a non-finite number, a value of the
            wrong type (a string or a boolean where a number belongs, a number where ``enabled``
            wants true or false), a value the effect or constants refuse (e.g. a negative
            stiffness), or constants of the other arm.
        """
        if not isinstance(data, Mapping):
            raise ValueError(f"robot parameters must be an object, got {type(data).__name__}")
        for key in data:
            if key not in _KEYS:
                raise ValueError(f"unknown robot parameter key {key!r}; known keys: {', '.join(_KEYS)}")
        arm = data.get("arm", "left")
        if arm not in ("left", "right"):
            raise ValueError(f"arm must be 'left' or 'right', got {arm!r}")
        constants = _from_fields("constants", RavenConstants(arm=arm), data.get("constants", {}))
        given = data.get("effects", {})
        if not isinstance(given, Mapping):
            raise ValueError(f"effects must be an object keyed by effect name, got {type(given).__name__}")
        for name in given:
            if name not in EFFECT_NAMES:
                raise ValueError(f"unknown effect {name!r} in effects; known effects: {', '.join(EFFECT_NAMES)}")
        effects = tuple(_from_fields(f"effects.{t.name}", t(), given.get(t.name, {})) for t in EFFECT_TYPES)
        gravity = data.get("gravity")
        if gravity is not None:
            gravity = _field_value("gravity", (0.0, 0.0, 0.0), gravity)
        return cls(arm=arm, constants=constants, effects=effects, gravity=gravity)

    def to_json(self, path: str | os.PathLike) -> Path:
        """Write :meth:`to_dict` as JSON to ``path``, atomically (a temporary file, then a rename).

        The file is complete or absent: a failure leaves any earlier file at ``path`` untouched.
        Returns the path written. Raises FileNotFoundError (naming the file) if its folder does not
        exist.
        """
        path = Path(path)
        folder = path.parent
        if not folder.is_dir():
            raise FileNotFoundError(f"cannot write {path}: folder {folder} does not exist")
        text = _dumps(self.to_dict()) + "\n"
        handle, temporary = tempfile.mkstemp(dir=folder, prefix=f".{path.name}.", suffix=".tmp")
        try:
            with os.fdopen(handle, "w", encoding="utf-8") as stream:
                stream.write(text)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(temporary, 0o666 & ~umask)
            os.replace(temporary, path)
        except BaseException:
            if os.path.exists(temporary):
                os.unlink(temporary)
            raise
        return path

    @classmethod
    def from_json(cls, path: str | os.PathLike) -> "RavenParameters":
        """Read a parameter set from a JSON file written by :meth:`to_json` (or by hand).

        Same rules as :meth:`from_dict` (a partial file describes only what differs from the virtual
        RAVEN-II); every error names the file. Raises FileNotFoundError for a missing file and
        ValueError for text that is not JSON (duplicate keys included) or parameters
        :meth:`from_dict` refuses.
        """
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise FileNotFoundError(f"robot parameter file {path} does not exist") from None
        try:
            data = json.loads(text, object_pairs_hook=_reject_duplicates)
        except ValueError as error:
            raise ValueError(f"{path}: not a valid JSON parameter file: {error}") from None
        try:
            return cls.from_dict(data)
        except ValueError as error:
            raise ValueError(f"{path}: {error}") from None

    def effect(self, name: str) -> Effect:
        """The effect object called ``name`` (switched off with defaults if not in ``effects``)."""
        for effect in self.effects:
            if effect.name == name:
                return effect
        return _switched_off(name)

    def is_enabled(self, name: str) -> bool:
        return self.effect(name).enabled

    @property
    def enabled_effects(self) -> tuple[str, ...]:
        """Names of the switched-on effects, in the engine's order."""
        return tuple(n for n in EFFECT_NAMES if self.is_enabled(n))

    def with_effect(self, effect: Effect) -> "RavenParameters":
        """A copy with ``effect`` replacing the effect of the same name (or added)."""
        others = tuple(e for e in self.effects if e.name != effect.name)
        order = {n: i for i, n in enumerate(EFFECT_NAMES)}
        effects = tuple(sorted(others + (effect,), key=lambda e: order[e.name]))
        return dataclasses.replace(self, effects=effects)

    def switched(self, names: Iterable[str], enabled: bool) -> "RavenParameters":
        """A copy with the named effects switched on or off (parameters kept)."""
        params = self
        for name in names:
            params = params.with_effect(params.effect(name).with_enabled(enabled))
        return params

    def without(self, *names: str) -> "RavenParameters":
        """A copy with the named effects switched off."""
        return self.switched(names, False)

    def only(self, *names: str) -> "RavenParameters":
        """A copy with exactly the named effects switched on."""
        for name in names:
            effect_type(name)
        return self.switched([n for n in EFFECT_NAMES if n not in names], False).switched(names, True)

    def describe(self) -> str:
        """Multi-line summary of the arm and every effect."""
        lines = [f"RAVEN-II {self.arm} arm"]
        lines += ["  " + self.effect(n).describe() for n in EFFECT_NAMES]
        return "\n".join(lines)
