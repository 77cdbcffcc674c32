"""The example scripts run: paper_cases.py writes the four figures (needs matplotlib, which
the test command does not install: skipped, with that reason, when it is missing), and
timings.py prints one row per method."""

import importlib.util
import subprocess
import sys

import pytest

from conftest import REPO

EXAMPLES = REPO / "examples" / "python"


@pytest.mark.skipif(
    importlib.util.find_spec("matplotlib") is None,
    reason="matplotlib is not installed (pip install matplotlib to run the figure example)",
)
def test_paper_cases_writes_four_figures(tmp_path):
    run = subprocess.run(
        [sys.executable, EXAMPLES / "paper_cases.py", "--samples", "2e5", "--out", tmp_path],
        capture_output=True, text=True,
    )
    assert run.returncode == 0, run.stderr
    figures = sorted(p.name for p in tmp_path.iterdir())
    assert figures == [f"fig{k}_case{k}.png" for k in range(1, 5)]
    for name in figures:
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_timings_prints_a_row_per_method(cli):
    run = subprocess.run(
        [sys.executable, EXAMPLES / "timings.py", "--repeat", "1", "--cli", cli],
        capture_output=True, text=True,
    )
    assert run.returncode == 0, run.stderr
    rows = [line for line in run.stdout.splitlines() if line.startswith("| ") and " s (" in line]
    assert [r.split("|")[1].strip() for r in rows] == ["epc", "epc-impact", "grid"]
