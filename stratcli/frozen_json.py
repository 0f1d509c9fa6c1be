"""Read-only JSON documents and mappings: the `document` of an outcome (result.json,
comparison.json, the check and decompose reports) and a model's strata, inside frozen values
(no I/O).

A frozen dataclass keeps its fields from being rebound, not a dict field from being changed:
`outcome.document["status"] = "ok"` changed a value that said it equals its pickle. They are
held as `FrozenDict` and `FrozenList`, subclasses of dict and list that refuse every change:
they still are dicts and lists to `json.dumps`, `==` (a document equals its file read back
with `json.load`), pandas and `isinstance`. A copy is a plain, changeable dict or list
(`copy.copy`, `copy.deepcopy`, `dict(doc)`, `doc.copy()`), and so is a pickled one read back
(it needs no stratplan to be read): the values holding them freeze them again
(`HoldsDocument`, by `MadeAgainOnUnpickling`, which the array values use too). YAML's
`safe_dump`, which takes plain dicts only, wants such a copy.
"""

from __future__ import annotations

from typing import Any, ClassVar, NoReturn

__all__ = [
    "FrozenDict",
    "FrozenList",
    "HoldsDocument",
    "MadeAgainOnUnpickling",
    "frozen",
    "thawed",
]


def _refuse(self, *args, **kwargs) -> NoReturn:
    raise TypeError(
        f"read-only ({type(self).__name__}: part of a frozen value); a copy (copy.deepcopy) "
        "can be changed"
    )


class FrozenDict(dict):
    """A dict that refuses every change (`frozen`)."""

    __slots__ = ()
    __setitem__ = __delitem__ = __ior__ = _refuse
    clear = pop = popitem = setdefault = update = _refuse

    def __reduce__(self):  # a plain dict (the default would fill it with __setitem__)
        return dict, (dict(self),)

    def __copy__(self) -> dict:
        return dict(self)

    def __deepcopy__(self, memo) -> dict:
        return thawed(self)


class FrozenList(list):
    """A list that refuses every change (`frozen`)."""

    __slots__ = ()
    __setitem__ = __delitem__ = __iadd__ = __imul__ = _refuse
    append = extend = insert = pop = remove = reverse = sort = clear = _refuse

    def __reduce__(self):
        return list, (list(self),)

    def __copy__(self) -> list:
        return list(self)

    def __deepcopy__(self, memo) -> list:
        return thawed(self)


def frozen(doc: Any) -> Any:
    """`doc` with every dict and list in it (tuples become lists, as JSON has them) read-only.

    Parameters
    ----------
    doc : Any
        A JSON-ready document: dicts, lists, tuples, strings, numbers, booleans, None.

    Returns
    -------
    Any
        The same document of `FrozenDict` and `FrozenList` (a frozen part as it is).
    """
    if isinstance(doc, FrozenDict | FrozenList):
        return doc
    if isinstance(doc, dict):
        return FrozenDict({key: frozen(value) for key, value in doc.items()})
    if isinstance(doc, list | tuple):
        return FrozenList(frozen(value) for value in doc)
    return doc


def thawed(doc: Any) -> Any:
    """A changeable copy of a document: plain dicts and lists all through."""
    if isinstance(doc, dict):
        return {key: thawed(value) for key, value in doc.items()}
    if isinstance(doc, list):
        return [thawed(value) for value in doc]
    return doc


class MadeAgainOnUnpickling:
    """A frozen dataclass whose `__post_init__` makes its parts read-only runs it again when
    unpickled (from a worker process, a file): numpy pickles its arrays writable, and a
    FrozenDict pickles as a plain dict (a plan from `--jobs` workers had writable arrays)."""

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        post_init = getattr(self, "__post_init__", None)
        if post_init is not None:
            post_init()


class HoldsDocument(MadeAgainOnUnpickling):
    """A frozen dataclass whose JSON fields (`_documents`: `document` unless a class names
    others) are held `frozen`: when made, and when unpickled or deep-copied (both bring plain
    dicts and lists back)."""

    _documents: ClassVar[tuple[str, ...]] = ("document",)

    def __post_init__(self) -> None:  # (run again when unpickled: `MadeAgainOnUnpickling`)
        for name in self._documents:
            object.__setattr__(self, name, frozen(getattr(self, name)))
