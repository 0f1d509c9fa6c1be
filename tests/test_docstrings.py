"""Every public function documents its parameters (numpydoc; python-control's
`docstrings_test.py` pattern): the functions of `stratcli.__all__` and of `stratcli.api`, and
the public methods of the classes in `stratcli.__all__` (`plan.controls(t)`, ...)."""

from __future__ import annotations

import inspect

import pytest

import stratcli
from stratcli import api


def _functions() -> dict[str, object]:
    found = {}
    for name in stratcli.__all__:
        if name == "__version__":
            continue
        obj = getattr(stratcli, name)
        if inspect.isfunction(obj):
            found[f"stratcli.{name}"] = obj
        elif inspect.isclass(obj):  # its own public methods (properties are not checked)
            for attr, member in vars(obj).items():
                if isinstance(member, (classmethod, staticmethod)):
                    member = member.__func__
                if not attr.startswith("_") and inspect.isfunction(member):
                    found[f"stratcli.{name}.{attr}"] = member
    for name in dir(api):
        obj = getattr(api, name)
        if not name.startswith("_") and inspect.isfunction(obj):
            found[f"stratcli.api.{name}"] = obj
    return found


FUNCTIONS = _functions()
# Known gaps, reported (tests may not edit stratcli/): strict, so a fix makes this list shrink.
UNDOCUMENTED: dict[str, str] = {}  # public functions allowed to lack sections (none)


def _section(doc: str, title: str) -> str | None:
    """The body of a numpydoc section (up to the next underlined title), or None."""
    lines = doc.splitlines()
    for i, line in enumerate(lines[:-1]):
        if line.strip() == title and set(lines[i + 1].strip()) == {"-"}:
            body = []
            for j in range(i + 2, len(lines)):
                nxt = lines[j + 1].strip() if j + 1 < len(lines) else ""
                if lines[j].strip() and nxt and set(nxt) == {"-"}:
                    break
                body.append(lines[j])
            return "\n".join(body)
    return None


def test_the_public_api_has_functions_to_check():
    assert {"stratcli.plan", "stratcli.load_scenario", "stratcli.api.plan_run"} <= set(FUNCTIONS)
    methods = {"stratcli.SequencePlan.controls", "stratcli.SequencePlan.from_dict"}
    assert methods | {"stratcli.System.stratum", "stratcli.Task.with_changes"} <= set(FUNCTIONS)


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.xfail(reason=UNDOCUMENTED[n], strict=True))
        if n in UNDOCUMENTED
        else n
        for n in sorted(FUNCTIONS)
    ],
)
def test_public_functions_document_their_parameters(name):
    obj = FUNCTIONS[name]
    doc = inspect.getdoc(obj) or ""
    signature = inspect.signature(obj)
    parameters = [
        p
        for p in signature.parameters.values()
        if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD) or p.name not in ("args", "kwargs")
        if p.name not in ("self", "cls")  # a method's own
    ]
    if parameters:
        section = _section(doc, "Parameters")
        assert section is not None, f"{name}: no Parameters section"
        documented = {
            part.strip().lstrip("*")
            for line in section.splitlines()
            if line and not line[0].isspace() and " :" in line
            for part in line.split(" :")[0].split(",")
        }
        missing = [p.name for p in parameters if p.name not in documented]
        assert not missing, f"{name}: parameters not documented: {missing}"
    returns_none = signature.return_annotation in (None, "None")
    if not returns_none:
        assert _section(doc, "Returns") is not None, f"{name}: no Returns section"


def test_no_submodule_hides_a_public_name():
    """Importing a submodule sets it as an attribute of its package, so a submodule named
    like a public function (once `stratcli/decompose.py` beside `stratcli.decompose`) would
    replace the function as soon as anything imported it. Import every module, then check."""
    import importlib
    import pkgutil
    import types

    import stratcli

    for info in pkgutil.walk_packages(stratcli.__path__, "stratcli."):
        if info.name.endswith("__main__"):
            continue
        try:
            importlib.import_module(info.name)
        except ImportError:  # an optional extra that is not installed
            continue
    for name in stratcli.__all__:
        assert not isinstance(getattr(stratcli, name), types.ModuleType), name


def _value_classes() -> dict[str, type]:
    import dataclasses

    return {
        name: obj
        for name in stratcli.__all__
        if inspect.isclass(obj := getattr(stratcli, name))
        and (dataclasses.is_dataclass(obj) or hasattr(obj, "model_fields"))
    }


@pytest.mark.parametrize("name", sorted(_value_classes()))
def test_every_public_value_class_names_each_of_its_fields(name):
    """`help(PlanOutcome)` never mentioned `result`, `document` or `phases`: a value class
    of `stratcli.__all__` says what each of its public fields holds (an Attributes section,
    or its prose), each field named as written."""
    import dataclasses

    cls = _value_classes()[name]
    if dataclasses.is_dataclass(cls):
        names = [f.name for f in dataclasses.fields(cls) if not f.name.startswith("_")]
    else:
        names = list(cls.model_fields)
    doc = inspect.getdoc(cls) or ""
    missing = [field for field in names if not re_word(field).search(doc)]
    assert not missing, f"{name}'s docstring does not name {missing}"


def re_word(word: str):
    import re

    return re.compile(rf"(?<![\w.]){re.escape(word)}(?!\w)")
