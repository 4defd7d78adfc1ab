"""examples/quickstart.ipynb runs from top to bottom in a Jupyter kernel
(nbclient, what `jupyter nbconvert --execute` uses), with the module from
PYTHONPATH as ctest sets it."""

import pytest

from conftest import SOURCE_DIR


def test_the_quickstart_notebook_runs_and_shows_its_run_tables_and_plot(tmp_path):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    notebook = nbformat.read(SOURCE_DIR / "examples" / "quickstart.ipynb", as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()  # CellExecutionError if a cell raises

    def shown(i):
        return "".join(str(o.get("data", {}).get("text/plain", "")) + o.get("text", "")
                       for o in notebook.cells[i].outputs)

    sources = [c.source for c in notebook.cells]
    at = {key: next(i for i, s in enumerate(sources) if key in s)
          for key in ("stickslip.run(", "to_xarray", "plt.subplots")}
    assert "μ = " in shown(at["stickslip.run("]) and "method" in shown(at["stickslip.run("])
    assert "<xarray.Dataset>" in shown(at["to_xarray"])
    assert any("image/png" in o.get("data", {}) for o in notebook.cells[at["plt.subplots"]].outputs)


def test_the_notebook_server_the_docs_name_is_installed():
    """USAGE.md opens the notebook with `jupyter notebook`: the set-up installs it."""
    import shutil
    import subprocess
    jupyter = shutil.which("jupyter")
    assert jupyter, "no jupyter command: scripts/install-deps installs jupyter-notebook"
    done = subprocess.run([jupyter, "notebook", "--version"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
