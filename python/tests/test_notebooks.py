"""The notebooks of examples/notebooks/ run from top to bottom (their last cells check the
numbers against Monte Carlo, so a change that breaks them fails here). Needs nbclient, nbformat,
ipykernel and matplotlib; skipped with the reason when one is missing."""

import pathlib

import pytest

NOTEBOOKS = pathlib.Path(__file__).resolve().parents[2] / "examples" / "notebooks"


@pytest.mark.parametrize("name", ["tutorial.ipynb"])
def test_notebook_runs(name, tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat", reason="nbformat is not installed")
    nbclient = pytest.importorskip("nbclient", reason="nbclient is not installed")
    pytest.importorskip("ipykernel", reason="ipykernel (the notebook's kernel) is not installed")
    pytest.importorskip("matplotlib", reason="matplotlib is not installed")
    notebook = nbformat.read(NOTEBOOKS / name, as_version=4)
    # Figures go to the temporary directory, not into the repository; no display needed.
    monkeypatch.setenv("MPLBACKEND", "Agg")
    client = nbclient.NotebookClient(
        notebook, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    )
    client.execute()
    outputs = [
        output.get("text", "")
        for cell in notebook.cells
        if cell.cell_type == "code"
        for output in cell.outputs
    ]
    assert any("EPC n = 8 within 2 % of Monte Carlo" in text for text in outputs)
    assert (tmp_path / "tutorial_pdf_z.png").stat().st_size > 10_000
