"""fpsolve's errors are also the builtin exceptions a caller would catch (issue 37 item 5),
keeping the fpsolve hierarchy and the command line's messages."""

import pickle

import pytest

import fpsolve

from conftest import MODELS


def test_a_missing_model_file_is_a_file_not_found_error(tmp_path):
    path = tmp_path / "absent.sde"
    with pytest.raises(FileNotFoundError) as info:
        fpsolve.Model.load(path)
    e = info.value
    assert isinstance(e, fpsolve.ModelError) and isinstance(e, fpsolve.FpsolveError)
    assert isinstance(e, ValueError)
    assert e.kind == "io" and e.filename == str(path)
    assert str(path) in str(e) and "Errno" not in str(e)


def test_a_bad_model_is_a_value_error():
    with pytest.raises(ValueError) as info:
        fpsolve.Model.from_text("model m\nstate z\n", "bad.sde")
    e = info.value
    assert isinstance(e, fpsolve.ModelError) and not isinstance(e, FileNotFoundError)
    assert e.line == 2 and "bad.sde:2" in str(e)


def test_a_bad_override_is_a_parameter_error_and_a_value_error(linear):
    with pytest.raises(fpsolve.ParameterError) as info:
        linear.solve("epc", degree=2, nope=1.0)
    assert isinstance(info.value, fpsolve.ModelError) and isinstance(info.value, ValueError)


def test_an_unknown_quantity_is_a_key_error_with_its_message(linear):
    sol = linear.solve("epc", degree=2)
    with pytest.raises(KeyError) as info:
        sol.pdf("nope", 0.0)
    e = info.value
    assert isinstance(e, fpsolve.UnknownQuantityError) and isinstance(e, fpsolve.SolveError)
    assert e.name == "nope" and "z" in e.known
    # KeyError would quote the message; it reads as written.
    assert str(e).startswith("`nope` is neither")


def test_an_existing_file_still_loads():
    assert fpsolve.Model.load(MODELS / "linear.sde").name
