"""Read-only JSON documents: the `document` of an outcome (result.json, comparison.json, the
check and decompose reports) inside a frozen value (no I/O).

A frozen dataclass keeps its fields from being rebound, not a dict field from being changed:
`outcome.document["status"] = "ok"` changed a value that said it equals its pickle. The
documents are held as `FrozenDict` and `FrozenList`, subclasses of dict and list that refuse
every change: they still are dicts and lists to `json.dumps`, `==` (a document equals its
file read back with `json.load`) and `isinstance`. `copy.deepcopy` of one is a plain,
changeable dict or list, for a caller who wants to edit a copy.
"""

from __future__ import annotations

from typing import Any, NoReturn

__all__ = ["FrozenDict", "FrozenList", "frozen", "thawed"]


def _refuse(self, *args, **kwargs) -> NoReturn:
    raise TypeError(
        f"a result document is read-only ({type(self).__name__}); copy.deepcopy(document) "
        "gives a copy to change"
    )


class FrozenDict(dict):
    """A dict that refuses every change (`frozen`)."""

    __slots__ = ()
    __setitem__ = __delitem__ = __ior__ = _refuse
    clear = pop = popitem = setdefault = update = _refuse

    def __reduce__(self):  # (pickled by its items: the default fills it with __setitem__)
        return type(self), (dict(self),)

    def __deepcopy__(self, memo) -> dict:
        return thawed(self)


class FrozenList(list):
    """A list that refuses every change (`frozen`)."""

    __slots__ = ()
    __setitem__ = __delitem__ = __iadd__ = __imul__ = _refuse
    append = extend = insert = pop = remove = reverse = sort = clear = _refuse

    def __reduce__(self):
        return type(self), (list(self),)

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
