"""manipkit.outputs with outputs that are not plain new files (issue 40): a command's own input, a replaced
file's mode, /dev/stdout and other links into /dev or /proc, /dev/null, FIFOs with and without a reader."""

import os
import stat
import threading
from pathlib import Path

import pytest
from cli_helper import run_cli

from manipkit.errors import OutputError
from manipkit.outputs import is_stream, write_text

FLAT = Path(__file__).parent / "bad_inputs" / "hostile_meshes" / "flat_mesh.urdf"


def test_acm_never_writes_over_the_robot_it_reads(tmp_path):
    robot = tmp_path / "robot.urdf"
    robot.write_text(FLAT.read_text())
    (tmp_path / "flat.stl").write_bytes((FLAT.parent / "flat.stl").read_bytes())
    before = robot.read_bytes()
    for output in (robot, tmp_path / "flat.stl"):  # the description, and a mesh it names
        result = run_cli("manipkit", "acm", "--robot", robot, "--samples", "50", "-o", output, cwd=tmp_path)
        # one error line; a warning about the folders around pytest's tmp_path (a package search) may precede it
        errors = [line for line in result.stderr.splitlines() if not line.startswith("warning: ")]
        assert result.returncode == 2 and len(errors) == 1, result.stderr
        assert "the command reads it (it is one of its inputs); give another output file name" in errors[0]
    assert robot.read_bytes() == before


def test_a_replaced_file_keeps_its_mode(tmp_path):
    path = tmp_path / "secret.srdf"
    path.write_text("old")
    path.chmod(0o600)
    write_text(path, "new")
    assert path.read_text() == "new" and stat.S_IMODE(path.stat().st_mode) == 0o600


def test_a_link_into_proc_is_written_through_not_replaced(tmp_path):
    """As /dev/stdout -> /proc/self/fd/1 (replaced by a regular file before, when run as root)."""
    target = tmp_path / "fd_target.txt"
    with open(target, "w") as held:
        link = tmp_path / "stdout"
        link.symlink_to(f"/proc/self/fd/{held.fileno()}")
        assert is_stream(link)
        write_text(link, "through the link\n")
        assert link.is_symlink()
    assert target.read_text() == "through the link\n"


def test_dev_null_takes_the_output_without_an_error():
    write_text("/dev/null", "x" * 1000)  # fsync of /dev/null failed with EINVAL after everything was written


def test_a_fifo_with_no_reader_is_refused_at_once(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    outcome = {}

    def write():
        try:
            write_text(fifo, "x")
        except OutputError as exc:
            outcome["error"] = str(exc)

    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    writer.join(timeout=10)
    if writer.is_alive():  # blocked in open(): give it a reader so the test ends, then fail
        with open(fifo, "rb") as reader:
            reader.read()
        pytest.fail("writing a FIFO with no reader blocked")
    assert outcome["error"] == (f"cannot write {fifo}: it is a FIFO (named pipe) that no process is reading; "
                                "start the reader first (cat FIFO &)")


def test_a_fifo_with_a_reader_gets_everything(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []
    reader_open = threading.Event()

    def read():
        with open(fifo, "rb") as reader:  # blocks until a writer opens
            reader_open.set()
            got.append(reader.read())

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    fd = os.open(fifo, os.O_WRONLY)  # meets the reader, so the reader is there before write_text looks
    reader_open.wait(10)
    try:
        write_text(fifo, "y" * 100_000)
    finally:
        os.close(fd)
    reader.join(timeout=10)
    assert got == [b"y" * 100_000]


def test_an_output_onto_the_file_stdout_is_redirected_to_is_refused(tmp_path):
    # run_cli gives the command a regular file as descriptor 1, as `manipkit ... -o /dev/stdout > out.txt` does:
    # before, the CSV was written from offset 0 and the report printed over it (measured: 8 report lines, no CSV)
    result = run_cli("manipkit", "path", "--robot", "ur5", "--line", "0.4", "0", "0.3", "0", "0", "0", "0.4", "0.05",
                     "0.3", "0", "0", "0", "--step", "0.02", "-o", "/dev/stdout", cwd=tmp_path)
    assert result.returncode == 2 and result.stdout == "", result.stdout
    assert result.stderr.count("\n") == 1 and "it is the file stdout is redirected to" in result.stderr, result.stderr
