"""Model.load / from_text / check, and model errors with their locations."""

import subprocess

import pytest

import fpsolve
from conftest import MODELS

LINEAR_TEXT = """model lin
param c = 0.5
state z, v
drift z: v
drift v: -c*v - z
noise xi: intensity 2
diffusion v: xi
observe en = v^2/2 + z^2/2
"""


def test_load_reads_names(vibro):
    assert vibro.name == "vibro_duffing"
    assert vibro.states == ("z", "v")
    assert vibro.observables == ("y", "ydot")
    assert vibro.quantities == ("z", "v", "y", "ydot")
    assert vibro.path.endswith("vibro_duffing.sde")


def test_load_accepts_pathlike_and_str():
    a = fpsolve.Model.load(MODELS / "linear.sde")
    b = fpsolve.Model.load(str(MODELS / "linear.sde"))
    assert a.parameters() == b.parameters()


def test_from_text_has_no_path():
    m = fpsolve.Model.from_text(LINEAR_TEXT)
    assert m.path is None
    assert m.quantities == ("z", "v", "en")


def test_parameters_with_overrides_numbers_and_expressions(vibro):
    p = vibro.parameters()
    assert list(p) == ["c", "k", "mu", "eps", "r", "K"]
    assert p["mu"] == 0.1
    q = vibro.parameters(mu=0.5, eps="-2*c")
    assert q["mu"] == 0.5
    assert q["eps"] == -0.2
    assert vibro.parameters()["mu"] == 0.1  # the model itself never changes


def test_check_is_the_cli_text(cli, vibro_impact):
    path = MODELS / "vibro_impact_duffing.sde"
    out = subprocess.run([cli, "check", path], capture_output=True, text=True, check=True)
    assert vibro_impact.check() == out.stdout


def test_check_with_override_is_the_cli_text(cli, vibro):
    path = MODELS / "vibro_duffing.sde"
    out = subprocess.run(
        [cli, "check", path, "--set", "mu=0.5"], capture_output=True, text=True, check=True
    )
    assert vibro.check(mu=0.5) == out.stdout


def test_syntax_error_is_located(tmp_path, cli):
    bad = tmp_path / "bad.sde"
    bad.write_text("model m\nstate z, v\ndrift z: v\ndrift v: -v - z +\n")
    with pytest.raises(fpsolve.ModelError) as info:
        fpsolve.Model.load(bad)
    e = info.value
    assert (e.kind, e.line, e.path) == ("syntax", 4, str(bad))
    assert e.column >= 1
    cli_out = subprocess.run([cli, "check", bad], capture_output=True, text=True)
    assert cli_out.returncode == 2
    assert str(e) in cli_out.stderr  # the same file:line:col message as the command line
    assert f"{bad}:4:{e.column}" in str(e)


def test_semantic_error_is_located_with_its_message():
    text = LINEAR_TEXT.replace("-c*v", "-cc*v")
    with pytest.raises(fpsolve.ModelError) as info:
        fpsolve.Model.from_text(text, path="mem.sde")
    e = info.value
    assert (e.kind, e.path, e.line, e.column) == ("semantic", "mem.sde", 5, 11)
    assert "cc" in e.message
    assert isinstance(e, fpsolve.FpsolveError)


def test_missing_file_is_a_model_error_without_location(tmp_path):
    with pytest.raises(fpsolve.ModelError) as info:
        fpsolve.Model.load(tmp_path / "nope.sde")
    assert info.value.kind == "io"
    assert info.value.line is None and info.value.column is None


def test_unknown_parameter_override_is_a_parameter_error(vibro):
    with pytest.raises(fpsolve.ParameterError) as info:
        vibro.solve("epc", degree=2, muu=1.0)
    assert info.value.kind == "bind"
    assert isinstance(info.value, fpsolve.ModelError)


def test_bad_override_expression_is_a_parameter_error(vibro):
    with pytest.raises(fpsolve.ParameterError) as info:
        vibro.parameters(mu="2*")
    assert info.value.kind == "set"


def test_override_of_wrong_type_is_a_type_error(vibro):
    with pytest.raises(ValueError):
        vibro.parameters(mu=[1, 2])


def test_numpy_scalars_and_other_reals_are_numbers(vibro):
    import fractions

    import numpy as np

    for value in (np.int64(1), np.float32(1.0), np.array(1.0), np.uint8(1), fractions.Fraction(1)):
        assert vibro.parameters(mu=value)["mu"] == 1.0, type(value)
    # The same binding serves solve and simulate.
    a = vibro.solve(method="epc", degree=2, mu=np.int64(1))
    b = vibro.solve(method="epc", degree=2, mu=1.0)
    assert a.coefficients == b.coefficients
    with pytest.raises(ValueError):
        vibro.parameters(mu=np.array([1.0, 2.0]))
