"""The public API's docstrings follow numpydoc, so that scripts/pydoc renders them: every public
method that takes arguments has a ``Parameters`` section naming each of them, and a
``Returns`` section when it returns something. Classes are added here as they are converted."""

import inspect

import pytest

import fpsolve

CONVERTED = [fpsolve.Solution]


def _public_methods(cls):
    for name, member in inspect.getmembers(cls):
        if name.startswith("_") or isinstance(inspect.getattr_static(cls, name), property):
            continue
        if callable(member):
            yield name, member


@pytest.mark.parametrize("cls", CONVERTED, ids=lambda c: c.__name__)
def test_public_methods_have_numpydoc_sections(cls):
    missing = []
    for name, method in _public_methods(cls):
        doc = inspect.getdoc(method) or ""
        params = [p for p in inspect.signature(method).parameters if p != "self"]
        if params and "Parameters\n----------" not in doc:
            missing.append(f"{cls.__name__}.{name}: no Parameters section")
        for p in params:
            if params and p not in doc.split("Parameters\n----------")[-1]:
                missing.append(f"{cls.__name__}.{name}: parameter {p} not described")
        if inspect.signature(method).return_annotation not in (None, "None") and (
            "Returns\n-------" not in doc
        ):
            missing.append(f"{cls.__name__}.{name}: no Returns section")
    assert not missing, "\n".join(missing)
