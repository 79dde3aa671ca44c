"""manipkit.outputs, the one way a file is written: whole or not at all, links replaced, inputs kept."""

import errno
import os
import stat

import pytest

from manipkit.errors import OutputError
from manipkit.outputs import writable_path, write_text, writing


def test_a_write_that_fails_midway_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    # issue 26: a full disk left a truncated page or an empty YAML
    target = tmp_path / "table.yaml"
    target.write_text("old\n")
    with pytest.raises(OutputError, match=f"^cannot write {target}: No space left on device$"):
        with writing(target) as partial:
            partial.write_text("half of the new")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["table.yaml"]


def test_a_writer_that_raises_anything_else_leaves_no_file(tmp_path):
    target = tmp_path / "plot.png"
    with pytest.raises(ZeroDivisionError):
        with writing(target) as partial:
            partial.write_bytes(b"\x89PNG")
            1 / 0  # noqa: B018 - the writer's own bug
    assert list(tmp_path.iterdir()) == []


def test_the_temporary_file_keeps_the_suffix_a_writer_reads_the_format_from(tmp_path):
    with writing(tmp_path / "tree.svg") as partial:
        assert partial.parent == tmp_path and partial.suffix == ".svg" and partial != tmp_path / "tree.svg"
        partial.write_text("<svg/>")
    assert (tmp_path / "tree.svg").read_text() == "<svg/>"


@pytest.mark.parametrize(("mask", "mode"), [(0o027, 0o640), (0o002, 0o664), (0o077, 0o600)])
def test_a_new_file_gets_the_mode_open_would_give_it(tmp_path, mask, mode):
    old = os.umask(mask)
    try:
        write_text(tmp_path / "a.txt", "x")
        assert os.umask(mask) == mask  # reading the mask left it as it was
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "a.txt").stat().st_mode) == mode  # 0o666 less the umask, not mkstemp's 0o600


def test_a_hard_link_to_an_input_counts_as_the_input(tmp_path):
    source = tmp_path / "robot.urdf"
    source.write_text("<robot/>")
    os.link(source, tmp_path / "same.urdf")
    with pytest.raises(OutputError, match="it is the command's input"):
        writable_path(tmp_path / "same.urdf", inputs=[source, None])
    assert writable_path(tmp_path / "other.urdf", inputs=[source]) == tmp_path / "other.urdf"


def test_a_file_name_with_a_nul_character_is_one_line(tmp_path):
    with pytest.raises(OutputError, match=r"a file name cannot hold a NUL character"):
        write_text(f"{tmp_path}/a\0b", "x")
