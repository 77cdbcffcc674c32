"""The public API's docstrings follow numpydoc, so that scripts/pydoc renders them: every public
method that takes arguments has a ``Parameters`` section naming each of them, and a
``Returns`` section when it returns something. Classes and functions are added here as they are converted."""

import inspect

import pytest

import fpsolve

CONVERTED = [fpsolve.Solution, fpsolve.Model, fpsolve.MonteCarlo, fpsolve.SweepResult, fpsolve.MonteCarloShard, fpsolve.Passage, fpsolve.PassageMonteCarlo, fpsolve.Transient, fpsolve.TransientHistory]
FUNCTIONS = [fpsolve.sweep, fpsolve.merge, fpsolve.run_job]


def _public_methods(cls):
    for name, member in inspect.getmembers(cls):
        if name.startswith("_") or isinstance(inspect.getattr_static(cls, name), property):
            continue
        if callable(member):
            yield name, member


def _missing(name, fn):
    """What ``fn``'s docstring lacks: a Parameters section naming every parameter, and a
    Returns section when it returns something."""
    doc = inspect.getdoc(fn) or ""
    params = [p for p in inspect.signature(fn).parameters if p != "self"]
    missing = []
    if params and "Parameters\n----------" not in doc:
        missing.append(f"{name}: no Parameters section")
    # numpydoc's entry lines: "name : type", "x1, x2 : type", "**set : type".
    described = set()
    for line in doc.split("Parameters\n----------")[-1].splitlines():
        if line and not line[0].isspace() and " :" in line:
            described |= {n.strip().lstrip("*") for n in line.split(" :")[0].split(",")}
    for p in params:
        if p not in described:
            missing.append(f"{name}: parameter {p} not described")
    if inspect.signature(fn).return_annotation not in (None, "None") and "Returns\n-------" not in doc:
        missing.append(f"{name}: no Returns section")
    return missing


@pytest.mark.parametrize("cls", CONVERTED, ids=lambda c: c.__name__)
def test_public_methods_have_numpydoc_sections(cls):
    missing = []
    for name, method in _public_methods(cls):
        missing += _missing(f"{cls.__name__}.{name}", method)
    assert not missing, "\n".join(missing)


@pytest.mark.parametrize("fn", FUNCTIONS, ids=lambda f: f.__name__)
def test_public_functions_have_numpydoc_sections(fn):
    missing = _missing(fn.__name__, fn)
    assert not missing, "\n".join(missing)
