"""Every notebook under notebooks/ runs end to end (nbclient, kernel ``python3``).

Each notebook is executed from a temporary copy, in the copy's folder, so neither outputs nor any
files a notebook writes end up in the repository. Needs ``nbclient``,
``nbformat`` and ``ipykernel`` (``pip install -e .[test]``) and a ``python3`` kernel
(``python -m ipykernel install --user`` if ``jupyter kernelspec list`` shows none).
"""

import os
import shutil
from pathlib import Path

import pytest

from jaxcable.core.config import cache_disabled_by_env

NOTEBOOK_DIR = Path(__file__).resolve().parent.parent / "notebooks"
NOTEBOOKS = sorted(p for p in NOTEBOOK_DIR.rglob("*.ipynb") if ".ipynb_checkpoints" not in p.parts)
CELL_TIMEOUT_S = 900


def _kernel_environment() -> dict:
    """This process's environment plus JAX's compilation-cache settings for the run's cache folder
    (``tests/conftest.py``): a notebook does not turn the cache on itself, and its kernel then reads
    back what the tests (and the other notebooks) compiled."""
    env = dict(os.environ)
    folder = env.get("JAXCABLE_TEST_CACHE_DIR")
    if folder and not cache_disabled_by_env():
        env.update(
            JAX_COMPILATION_CACHE_DIR=folder,
            JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="0",
            JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES="-1",
        )
    return env


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[str(p.relative_to(NOTEBOOK_DIR)) for p in NOTEBOOKS])
def test_notebook_runs(path, tmp_path):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")

    copy_dir = tmp_path / path.parent.relative_to(NOTEBOOK_DIR)
    copy_dir.mkdir(parents=True, exist_ok=True)
    copy = copy_dir / path.name
    shutil.copy(path, copy)
    nb = nbformat.read(copy, as_version=4)
    client = nbclient.NotebookClient(
        nb,
        timeout=CELL_TIMEOUT_S,
        kernel_name="python3",
        resources={"metadata": {"path": str(copy_dir)}},
    )
    client.execute(env=_kernel_environment())  # raises CellExecutionError with the failing cell's traceback
    errors = [
        out
        for cell in nb.cells
        if cell.cell_type == "code"
        for out in cell.get("outputs", [])
        if out.get("output_type") == "error"
    ]
    assert not errors, errors


def test_notebooks_found():
    assert NOTEBOOKS, f"no notebooks under {NOTEBOOK_DIR}"


def test_notebooks_saved_without_outputs():
    """Keep the repository small: notebooks are committed with cleared outputs."""
    nbformat = pytest.importorskip("nbformat")
    for path in NOTEBOOKS:
        nb = nbformat.read(path, as_version=4)
        for cell in nb.cells:
            if cell.cell_type == "code":
                assert not cell.get("outputs") and cell.get("execution_count") is None, f"{path.name} has outputs"
