"""The build backend of source installs: maturin, after a check that Rust is there.

Without a Rust toolchain, maturin either fails with a long traceback or downloads one; a
user of ``pip install fpsolve`` from source (an sdist, a checkout) should instead read one line
that says what is missing. Every hook that needs cargo checks ``cargo --version`` and
``rustc --version`` first (the ``CARGO`` and ``RUSTC`` variables are honoured, as cargo and
maturin do), then hands over to maturin unchanged. Installing a wheel never runs this file.
"""

import os
import re
import shutil
import subprocess
import sys

import maturin

#: The oldest Rust that compiles fpsolve (the crates' ``rust-version``).
MINIMUM_RUST = (1, 89)

_INSTALL_HINT = "install it from https://rustup.rs or use a prebuilt wheel (pip install --only-binary fpsolve fpsolve)"


def _version_of(tool):
    """``(major, minor)`` of ``tool --version``, or a sentence saying why it is unknown."""
    program = os.environ.get(tool.upper()) or shutil.which(tool)
    if not program:
        return f"`{tool}` was not found on PATH"
    try:
        out = subprocess.run(
            [program, "--version"], capture_output=True, text=True, timeout=60
        )
    except OSError as error:
        return f"`{program} --version` could not run ({error})"
    match = re.match(rf"{tool} (\d+)\.(\d+)", out.stdout)
    if out.returncode != 0 or not match:
        return f"`{program} --version` printed no version"
    return int(match.group(1)), int(match.group(2))


def rust_problem():
    """What keeps this machine from building fpsolve from source, or None when Rust will do."""
    for tool in ("cargo", "rustc"):
        found = _version_of(tool)
        if isinstance(found, str):
            return found
        if found < MINIMUM_RUST:
            return f"{tool} {found[0]}.{found[1]} is older than {MINIMUM_RUST[0]}.{MINIMUM_RUST[1]}"
    return None


def _require_rust():
    problem = rust_problem()
    if problem is not None:
        need = f"{MINIMUM_RUST[0]}.{MINIMUM_RUST[1]}"
        # One line and a plain exit, not an exception: the frontend prints the hook's output
        # as it is, and a traceback would bury the line.
        print(
            f"error: building fpsolve from source needs Rust >= {need}: {problem}; {_INSTALL_HINT}",
            file=sys.stderr,
        )
        sys.exit(1)


def get_requires_for_build_wheel(config_settings=None):
    _require_rust()
    return maturin.get_requires_for_build_wheel(config_settings)


def get_requires_for_build_editable(config_settings=None):
    _require_rust()
    return maturin.get_requires_for_build_editable(config_settings)


def get_requires_for_build_sdist(config_settings=None):
    _require_rust()
    return maturin.get_requires_for_build_sdist(config_settings)


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    _require_rust()
    return maturin.prepare_metadata_for_build_wheel(metadata_directory, config_settings)


def prepare_metadata_for_build_editable(metadata_directory, config_settings=None):
    _require_rust()
    return maturin.prepare_metadata_for_build_editable(metadata_directory, config_settings)


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    _require_rust()
    return maturin.build_wheel(wheel_directory, config_settings, metadata_directory)


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    _require_rust()
    return maturin.build_editable(wheel_directory, config_settings, metadata_directory)


def build_sdist(sdist_directory, config_settings=None):
    _require_rust()
    return maturin.build_sdist(sdist_directory, config_settings)
