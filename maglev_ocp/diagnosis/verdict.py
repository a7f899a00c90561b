"""The verdict as a type: the effect sets a diagnosis names, with one text form for the report.

A verdict is ``none`` (no gap beyond the noise), ``unexplained`` (a gap the
library does not account for), or one or more **slots** of effects: each
slot holds the effect the selection chose and the alternatives that fit the
held-out runs as well (confusable). A verdict naming effects can also be
**partly explained**: the effects found and a gap they leave that is located
(a spectral line, a period in d that is no library period, ...) but that no
library effect accounts for. Its text form, the report's vocabulary, joins a
slot's members by ``|``, the slots by ``+`` and ends a partly explained verdict
with ``+unexplained``::

    none | unexplained | cogging | friction|eddy_drag | cogging+friction | end_effect|saturation+friction
    cogging+unexplained | cogging+friction+unexplained

:meth:`EffectSets.parse` and ``str()`` are the only conversions between the
two; every stage reads the structure (:attr:`EffectSets.effects`,
:attr:`EffectSets.names`, :attr:`EffectSets.slots`), never the text.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass

#: The verdict when no gap is found beyond the noise.
NONE: str = "none"
#: The verdict when a gap is found that no library effect (or set of them) accounts for.
UNEXPLAINED: str = "unexplained"


@dataclass(frozen=True)
class EffectSets:
    """What a verdict names: ``none``, ``unexplained``, or slots of effects.

    Attributes
    ----------
    slots : tuple of tuple of str
        Per effect the selection named, the effect first and then its
        confusable alternatives; empty for ``none`` and ``unexplained``.
    unexplained : bool
        A gap that no slot accounts for (only without slots).
    gap : bool
        Partly explained: the slots' effects leave a located gap that no library
        effect accounts for (only with slots; text form ``...+unexplained``).
    """

    slots: tuple[tuple[str, ...], ...] = ()
    unexplained: bool = False
    gap: bool = False

    def __post_init__(self) -> None:
        if self.slots and self.unexplained:
            raise ValueError("an unexplained verdict names no effect")
        if self.gap and not self.slots:
            raise ValueError("a partly explained verdict names effects")
        if any(not s or any(not n or "|" in n or "+" in n or n in (NONE, UNEXPLAINED) for n in s) for s in self.slots):
            raise ValueError(f"malformed effect slots {self.slots!r}")

    @classmethod
    def none(cls) -> EffectSets:
        """No gap beyond the noise."""
        return cls()

    @classmethod
    def gap_unexplained(cls) -> EffectSets:
        """A gap that the library does not account for."""
        return cls((), True)

    @classmethod
    def of(cls, slots: Iterable[Sequence[str]]) -> EffectSets:
        """Effect slots (each: the chosen effect, then its confusable alternatives)."""
        return cls(tuple(tuple(s) for s in slots))

    @classmethod
    def parse(cls, text: str) -> EffectSets:
        """The verdict of its text form (``none``, ``unexplained``, ``a``, ``a|b``, ``a+b``, ``a|b+c``,
        ``a+unexplained``)."""
        text = text.strip()
        if text == NONE:
            return cls.none()
        if text == UNEXPLAINED:
            return cls.gap_unexplained()
        parts = text.split("+")
        gap = parts[-1] == UNEXPLAINED
        if gap:
            parts = parts[:-1]
        return cls(tuple(tuple(slot.split("|")) for slot in parts), gap=gap)

    def __str__(self) -> str:
        if self.unexplained:
            return UNEXPLAINED
        if not self.slots:
            return NONE
        return "+".join("|".join(s) for s in self.slots) + (f"+{UNEXPLAINED}" if self.gap else "")

    def partly(self, gap: bool = True) -> EffectSets:
        """The same effects with (``gap``) or without a located gap they leave; ``unexplained`` stays as it is
        and ``none`` with a gap is ``unexplained``."""
        if not self.slots:
            return EffectSets.gap_unexplained() if gap else self
        return EffectSets(self.slots, gap=gap)

    @property
    def named(self) -> bool:
        """Whether the verdict names effects (neither ``none`` nor ``unexplained``)."""
        return bool(self.slots)

    @property
    def effects(self) -> tuple[str, ...]:
        """The chosen effect of every slot, in selection order."""
        return tuple(s[0] for s in self.slots)

    @property
    def names(self) -> tuple[str, ...]:
        """Every effect the verdict mentions: each slot's effect and its alternatives, in order."""
        return tuple(n for s in self.slots for n in s)

    @property
    def head(self) -> str:
        """The effect a single-slot verdict is scored by (its first member); else the text form of the effects."""
        if len(self.slots) == 1:
            return self.slots[0][0]
        return "+".join(self.effects) if self.slots else str(self)

    def matches(self, truth: EffectSets, order: Sequence[str]) -> bool:
        """Whether this verdict names exactly ``truth``'s effects (a confusable set is not right).

        A partly explained verdict is right for the effects it names: ``cogging+unexplained`` matches a truth
        ``cogging`` (the effects found, and a gap they leave that no library effect accounts for); it never
        matches ``unexplained`` or ``none`` (it claims effects).
        """
        if self.gap and not truth.gap:
            return EffectSets(self.slots).canonical(order) == truth.canonical(order)
        return self.canonical(order) == truth.canonical(order)

    def without(self, names: Collection[str]) -> EffectSets:
        """The verdict with ``names`` dropped: the members of a single slot (``a|b`` less ``a`` is ``b``), the
        slots of a set (``a+b`` less ``a`` is ``b``); ``unexplained`` when nothing is left."""
        if not self.slots:
            return self
        if len(self.slots) == 1:
            keep = [n for n in self.slots[0] if n not in names]
            return EffectSets((tuple(keep),), gap=self.gap) if keep else EffectSets.gap_unexplained()
        keep_slots = tuple(s for s in self.slots if s[0] not in names)
        return EffectSets(keep_slots, gap=self.gap) if keep_slots else EffectSets.gap_unexplained()

    def canonical(self, order: Sequence[str]) -> str:
        """Text form with a set of plain effects (``b+a``) in ``order`` (``a+b``); others as they are (a
        partly explained verdict keeps its ``+unexplained`` last)."""
        if len(self.slots) < 2 or any(len(s) > 1 for s in self.slots):
            return str(self)
        text = "+".join(sorted(self.effects, key=lambda n: order.index(n) if n in order else len(order)))
        return text + (f"+{UNEXPLAINED}" if self.gap else "")


@dataclass
class Verdict:
    """The verdict and how it was reached.

    Attributes
    ----------
    sets : EffectSets
        What is named (a text form is parsed: ``Verdict("a|b", ...)``).
    selected : list of str
        Effects in the verdict, ranked.
    gap_detected : bool
        The baseline residual has a gap above the floor.
    reasons : list of str
        Plain-language steps of the decision.
    """

    sets: EffectSets
    selected: list[str]
    gap_detected: bool
    reasons: list[str]

    def __post_init__(self) -> None:
        if isinstance(self.sets, str):
            self.sets = EffectSets.parse(self.sets)

    @property
    def verdict(self) -> str:
        """The report's text form: ``none``, ``unexplained``, an effect, ``a|b`` (confusable), ``a+b`` (a set)."""
        return str(self.sets)

    @property
    def named(self) -> bool:
        """Whether the verdict names effects."""
        return self.sets.named


__all__ = ["NONE", "UNEXPLAINED", "EffectSets", "Verdict"]
