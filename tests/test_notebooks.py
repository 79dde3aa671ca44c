"""Every notebook in notebooks/ runs top to bottom in a fresh kernel (no hidden state, no network)."""

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))


def test_the_notebooks_exist():
    names = [p.name for p in NOTEBOOKS]
    assert names == [
        "01_planar_2r.ipynb",
        "02_planar_3r_workspace.ipynb",
        "03_rotations.ipynb",
        "04_course_arm.ipynb",
        "05_iiwa_dh.ipynb",
        "06_decoupled_ik.ipynb",
        "07_numerical_ik.ipynb",
        "08_velocity_kinematics.ipynb",
        "09_reach_maps.ipynb",
        "10_closed_form_real_arms.ipynb",
        "11_collisions.ipynb",
        "12_statics.ipynb",
        "13_task_paths.ipynb",
        "14_every_solution.ipynb",
    ]


@pytest.fixture(scope="module")
def executed(tmp_path_factory):
    """Each notebook run top to bottom in a fresh kernel of its own, two kernels at a time: path -> future.

    A kernel is a process of its own, so two run side by side; the reach maps notebook, the longest, starts first.
    nbclient's timeout (120 s a cell) only stops a hung cell; no test asserts a time (speed goals live in benchmarks/).
    """

    def execute(path):
        notebook = nbformat.read(path, as_version=4)
        folder = tmp_path_factory.mktemp(path.stem)
        client = NotebookClient(notebook, timeout=120, kernel_name="python3", resources={"metadata": {"path": str(folder)}})
        # the kernel's own stderr to a file beside it: started from a thread, it would print between tests
        with open(folder / "kernel_stderr.txt", "w") as stderr:
            client.execute(stderr=stderr)
        return notebook

    with ThreadPoolExecutor(max_workers=2) as pool:
        yield {path: pool.submit(execute, path) for path in sorted(NOTEBOOKS, key=lambda p: "reach_maps" not in p.name)}


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_top_to_bottom(path, executed):
    stored = nbformat.read(path, as_version=4)
    # Stored without outputs (small diffs, no stale numbers).
    assert all(not cell.get("outputs") for cell in stored.cells if cell.cell_type == "code")
    # Prose explains the math, not only code.
    assert sum(cell.cell_type == "markdown" for cell in stored.cells) >= 4
    notebook = executed[path].result()  # a cell that raised raises here (nbclient's CellExecutionError)
    errors = [o for c in notebook.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors
