"""The in-tree build backend's Rust check (python/_build/fpsolve_build.py): a source install
without Rust >= 1.89 stops with one line before maturin runs."""

import importlib.util
import pathlib
import stat
import sys

import pytest

pytest.importorskip("maturin")

BACKEND = pathlib.Path(__file__).resolve().parents[1] / "_build" / "fpsolve_build.py"


def load_backend():
    spec = importlib.util.spec_from_file_location("fpsolve_build", BACKEND)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def fake_toolchain(directory, cargo, rustc):
    """Scripts named cargo and rustc that print the given `--version` lines."""
    for name, line in (("cargo", cargo), ("rustc", rustc)):
        if line is None:
            continue
        path = directory / name
        path.write_text(f"#!/bin/sh\necho '{line}'\n")
        path.chmod(path.stat().st_mode | stat.S_IEXEC)


@pytest.fixture
def backend(monkeypatch):
    monkeypatch.delenv("CARGO", raising=False)
    monkeypatch.delenv("RUSTC", raising=False)
    return load_backend()


pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="fake toolchains are sh scripts")


def test_missing_cargo_is_one_line_and_exit_1(backend, monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("PATH", str(tmp_path))
    assert backend.rust_problem() == "`cargo` was not found on PATH"
    with pytest.raises(SystemExit) as stop:
        backend.get_requires_for_build_wheel()
    assert stop.value.code == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("error: building fpsolve from source needs Rust >= 1.89: ")


@pytest.mark.parametrize(
    "cargo, rustc, problem",
    [
        ("cargo 1.80.0 (3f5fd8dd4 2024-08-06)", "rustc 1.80.0 (051478957 2024-07-21)",
         "cargo 1.80 is older than 1.89"),
        ("cargo 1.89.0 (c24e10642 2025-06-23)", "rustc 1.88.0 (6b00bc388 2025-06-23)",
         "rustc 1.88 is older than 1.89"),
        ("cargo 1.89.0 (c24e10642 2025-06-23)", None, "`rustc` was not found on PATH"),
        ("cargo: command failed", "rustc 1.95.0", f"`{{dir}}/cargo --version` printed no version"),
    ],
)
def test_old_or_broken_toolchains_are_named(backend, monkeypatch, tmp_path, cargo, rustc, problem):
    fake_toolchain(tmp_path, cargo, rustc)
    monkeypatch.setenv("PATH", str(tmp_path))
    assert backend.rust_problem() == problem.format(dir=tmp_path)


@pytest.mark.parametrize("version", ["1.89.0", "1.95.0", "2.0.0"])
def test_recent_enough_rust_passes(backend, monkeypatch, tmp_path, version):
    fake_toolchain(tmp_path, f"cargo {version} (x 2026-01-01)", f"rustc {version} (x 2026-01-01)")
    monkeypatch.setenv("PATH", str(tmp_path))
    assert backend.rust_problem() is None


def test_cargo_variable_is_honoured(backend, monkeypatch, tmp_path):
    fake_toolchain(tmp_path, "cargo 1.70.0 (x 2023-06-01)", "rustc 1.95.0 (x 2026-01-01)")
    monkeypatch.setenv("PATH", "/nonexistent")
    monkeypatch.setenv("CARGO", str(tmp_path / "cargo"))
    monkeypatch.setenv("RUSTC", str(tmp_path / "rustc"))
    assert backend.rust_problem() == "cargo 1.70 is older than 1.89"
