"""How a typed summary is read from and written to the run store (shared by every summary)."""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping
from typing import Any, ClassVar, Self, TypeVar

__all__: list[str] = []

_T = TypeVar("_T")


def _known(cls: type[_T], summary: Mapping[str, Any]) -> dict[str, Any]:
    """The items of ``summary`` that are fields of the dataclass ``cls``."""
    names = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    return {k: v for k, v in summary.items() if k in names}


class _Flat:
    """A summary stored as its own fields: read from any release's (a key it lacks takes its
    default, a key it does not know is left out), written as every field in order."""

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any]) -> Self:
        """Read the stored form."""
        return cls(**_known(cls, summary))

    def to_summary(self) -> dict[str, Any]:
        """The stored form: every field."""
        return dataclasses.asdict(self)  # type: ignore[call-overload]


def _plain(value: Any) -> Any:
    """``value`` as JSON: a typed summary by its ``to_summary``, lists and dicts item by item,
    anything else copied (the stored form shares nothing with the object)."""
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if hasattr(value, "to_summary"):
        return value.to_summary()
    return copy.deepcopy(value)


def stored_as(key: str, default: Any = None, *, factory: Any = None) -> Any:
    """A field stored under ``key`` instead of its own name.

    The store's keys are a file format: summaries written when the angle was the only
    response name their response values ``aor_deg`` and stores of every release must read
    back. A field with a generic name (``value``) keeps that key here, in its declaration,
    and nowhere else. ``factory`` makes a mutable default (a list).
    """
    if factory is not None:
        return dataclasses.field(default_factory=factory, metadata={"key": key})
    return dataclasses.field(default=default, metadata={"key": key})


def _key(f: dataclasses.Field) -> str:
    """The stored key of the field ``f``."""
    return f.metadata.get("key", f.name)


def stored_key(cls: Any, name: str) -> str:
    """The stored key of the field ``name`` of the dataclass ``cls`` (a class or an instance)."""
    return next(_key(f) for f in dataclasses.fields(cls) if f.name == name)


def by_key(obj: Any, names: tuple[str, ...] | list[str]) -> dict[str, Any]:
    """The fields ``names`` of the dataclass ``obj`` under their stored keys, in that order
    (a file format built from a summary's fields: the result JSON)."""
    keys = {f.name: _key(f) for f in dataclasses.fields(obj)}
    return {keys[name]: getattr(obj, name) for name in names}


def _read(cls: type[_T], summary: Mapping[str, Any]) -> dict[str, Any]:
    """The constructor's arguments from a stored summary: each field's stored key that
    ``summary`` holds (a key it lacks takes the default; one it does not know is left out)."""
    return {f.name: summary[_key(f)] for f in dataclasses.fields(cls)  # type: ignore[arg-type]
            if _key(f) in summary}


def _stored(obj: Any, always: tuple[str, ...] = ()) -> dict[str, Any]:
    """The stored form of the dataclass ``obj``: each field under its stored key, in order,
    nested summaries by their own ``to_summary``; a field not named in ``always`` only where
    it is not None (a key its producer did not write stays out, so a summary reads back to
    the same keys)."""
    return {_key(f): _plain(v) for f in dataclasses.fields(obj)
            if (v := getattr(obj, f.name)) is not None or f.name in always}


class _Keyed:
    """A summary stored under its fields' stored keys (:func:`stored_as`): read from any
    release's, written with the fields named in ``ALWAYS`` even when None and the others
    where set."""

    #: the fields written even when None
    ALWAYS: ClassVar[tuple[str, ...]] = ()

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any] | None) -> Self:
        """Read the stored form."""
        return cls(**_read(cls, summary or {}))

    def to_summary(self) -> dict[str, Any]:
        """The stored form."""
        return _stored(self, self.ALWAYS)


class _KeyedEvery(_Keyed):
    """A :class:`_Keyed` summary written with every field, None or not."""

    def to_summary(self) -> dict[str, Any]:
        """The stored form: every field."""
        return _stored(self, tuple(f.name for f in dataclasses.fields(self)))  # type: ignore[arg-type]


class _InRounds:
    """A summary kept per refinement round: its ``round`` (None: the first) and the earlier
    rounds' summaries in ``rounds``."""

    round: int | None
    rounds: list[Any]

    @property
    def round_number(self) -> int:
        """The refinement round, 1 for the first."""
        return self.round or 1

    def in_round(self, earlier: list[Self]) -> Self:
        """This summary as stored in its round: with the ``earlier`` rounds' as its history
        (each without its own), and any history it carried dropped."""
        return dataclasses.replace(  # type: ignore[type-var]
            self, rounds=[dataclasses.replace(e, rounds=[]) for e in earlier])  # type: ignore[type-var]
