"""The parameter set of a virtual RAVEN-II arm: hardware constants plus named effects."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Iterable

import numpy as np

from simulation.model.constants import RavenConstants
from simulation.model.effects import EFFECT_NAMES, EFFECT_TYPES, Effect, effect_type


def _default_effects() -> tuple[Effect, ...]:
    return tuple(t() for t in EFFECT_TYPES)


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

    def effect(self, name: str) -> Effect:
        """The effect object called ``name`` (switched off with defaults if not in ``effects``)."""
        effect_type(name)
        for effect in self.effects:
            if effect.name == name:
                return effect
        return effect_type(name)(enabled=False)

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
