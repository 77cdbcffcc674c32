"""Shared fixtures: the repository's models and the command-line binary the Python results are
compared with (built with `cargo build --release` when absent)."""

import csv
import os
import pathlib
import subprocess

import numpy as np
import pytest

import fpsolve

REPO = pathlib.Path(__file__).resolve().parents[2]
MODELS = REPO / "models"


def cli_path() -> pathlib.Path:
    """The release binary: $FPSOLVE_CLI, or target/release/fpsolve of this repository (of
    $CARGO_TARGET_DIR when set)."""
    if "FPSOLVE_CLI" in os.environ:
        return pathlib.Path(os.environ["FPSOLVE_CLI"])
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    return target / "release" / "fpsolve"


def read_csv(path):
    """A CSV file the CLI wrote: its header and {column: array}. float() of the printed text
    is the number written: the CLI prints shortest round-trip decimals (and "NaN")."""
    with open(path) as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return header, {h: np.array([float(r[k]) for r in body]) for k, h in enumerate(header)}


@pytest.fixture(scope="session")
def cli() -> pathlib.Path:
    path = cli_path()
    if not path.exists():
        subprocess.run(
            ["cargo", "build", "--release", "--bin", "fpsolve"], cwd=REPO, check=True
        )
    assert path.exists(), f"no fpsolve binary at {path}"
    return path


@pytest.fixture(scope="session")
def vibro() -> fpsolve.Model:
    """The paper's model in Zhuravlev form (Eq. 10)."""
    return fpsolve.Model.load(MODELS / "vibro_duffing.sde")


@pytest.fixture(scope="session")
def vibro_impact() -> fpsolve.Model:
    """The paper's Eqs. 1-2 as written (a reflecting barrier at y = 0)."""
    return fpsolve.Model.load(MODELS / "vibro_impact_duffing.sde")


@pytest.fixture(scope="session")
def linear() -> fpsolve.Model:
    """The linear oscillator: exact Gaussian PDF, Var z = pi K / (c k), Var v = pi K / c."""
    return fpsolve.Model.load(MODELS / "linear.sde")
