"""``tf-between`` (issue 15): inputs that are not regular files, deep chains, --compare limits, streamed --q-file.

Every test runs the command as a user would, in this process
(tests/cli_helper.py), or in a subprocess with a timeout where the test is
about the process (a read that would block forever, a crash, peak memory);
inputs that cannot be committed (FIFOs, symlink loops, files above a size
limit, generated chains) are made here in a temporary folder. The committed
cases are in tests/bad_inputs/cases_inputs.yaml.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cli_helper import run_cli
from reference import POSE_A, POSE_B, course_arm_T_base_ee

BIN = Path(sys.executable).parent
JOINTS = ("arm_base_joint", "shoulder_joint", "bottom_wrist_joint", "elbow_joint", "top_wrist_joint")
#: Rows of the generated --q-file of the memory test in CSV (10^6, about 12 s here) and in JSON Lines
#: (2 x 10^5 by default: JSON writes 33 shortest-repr floats a row, about 25 s for 10^6 rows on this machine;
#: MANIPKIT_Q_FILE_ROWS=1000000 runs both at 10^6).
CSV_ROWS = int(os.environ.get("MANIPKIT_Q_FILE_ROWS", 100_000))
JSONL_ROWS = int(os.environ.get("MANIPKIT_Q_FILE_ROWS", 40_000))
SHORT_ROWS = 1_000  # the file whose peak is the process's own (the imports, the robot): about 230 MB here
PEAK_MEMORY_LIMIT_KB = 500 * 1024
#: Growth allowed from the short file to the long one, per format: half of what reading the long file whole adds
#: (CSV about 60 MB, JSON Lines about 200 MB); a streamed run was seen at +30 MB for JSON Lines once under load.
MEMORY_GROWTH_LIMIT_KB = {"csv": 30 * 1024, "jsonl": 100 * 1024}


def run_process(*args, timeout=120):
    """``tf-between ARGS`` in a subprocess, for the tests about the process (each says why)."""
    return subprocess.run([str(BIN / "tf-between"), *map(str, args)], capture_output=True, text=True, timeout=timeout)


def assert_one_line_error(result, fragment):
    assert result.returncode == 2, result.stdout[-2000:] + result.stderr
    assert result.stderr.startswith("tf-between: error: ") and result.stderr.count("\n") == 1, result.stderr
    assert fragment in result.stderr, result.stderr
    assert "Traceback" not in result.stdout + result.stderr


def chain_urdf(path: Path, links: int) -> Path:
    """A chain of ``links`` fixed joints l0 - l1 - ... - l<links>, each 1 mm above the one before."""
    rows = ['<robot name="chain">', '<link name="l0"/>']
    for i in range(1, links + 1):
        rows.append(f'<link name="l{i}"/><joint name="j{i}" type="fixed"><parent link="l{i - 1}"/>'
                    f'<child link="l{i}"/><origin xyz="0 0 0.001"/></joint>')
    path.write_text("\n".join(rows + ["</robot>"]))
    return path


# ---------------------------------------------------------------- inputs that are not regular files


@pytest.mark.parametrize("option", ["--robot", "--q-file", "--compare"])
def test_a_fifo_is_refused_at_once_not_read(option, tmp_path):
    fifo = tmp_path / ("named_pipe.urdf" if option == "--robot" else "named_pipe.csv")
    os.mkfifo(fifo)
    # a subprocess with a timeout: reading the FIFO would block forever
    result = run_process("base_link", "ee_link", option, fifo, timeout=60)
    assert_one_line_error(result, f"{fifo} is a FIFO (named pipe), not a regular file; give a file")


@pytest.mark.parametrize("option", ["--robot", "--q-file", "--compare"])
def test_a_symlink_loop_is_named_as_such(option, tmp_path):
    loop = tmp_path / "loop.urdf"
    loop.symlink_to(loop.name)
    result = run_cli("tf-between", "base_link", "ee_link", option, loop)
    assert_one_line_error(result, f"{loop} is a symlink loop (it points back to itself)")


def test_an_empty_robot_name_is_not_a_folder():
    result = run_cli("tf-between", "base_link", "ee_link", "--robot", "")
    assert_one_line_error(result, "the robot name is empty; give a bundled name")
    assert " is a folder" not in result.stderr


def test_a_robot_file_above_the_size_limit_is_refused_before_reading(tmp_path):
    huge = tmp_path / "huge.urdf"
    with open(huge, "wb") as stream:
        stream.truncate(65 * 1024 * 1024)  # sparse: 65 MB that take no disk space
    assert_one_line_error(run_cli("tf-between", "base_link", "ee_link", "--robot", huge), "is 65 MB, above the limit of 64 MB for a robot file")


def test_a_compare_file_above_the_size_limit_is_refused_before_reading(tmp_path):
    huge = tmp_path / "hand.txt"
    with open(huge, "wb") as stream:
        stream.truncate(100 * 1024 * 1024)
    assert_one_line_error(run_cli("tf-between", "base_link", "ee_link", "--compare", huge), "is 100 MB, above the limit of 1 MB for a matrix file")


def test_a_nan_entry_in_a_compare_matrix_exits_2_with_one_line(tmp_path):
    hand = tmp_path / "hand.txt"
    hand.write_text("1 0 0 0\n0 1 0 NaN\n0 0 1 0\n0 0 0 1\n")
    assert_one_line_error(run_cli("tf-between", "base_link", "ee_link", "--compare", hand), "row 2, entry 4 is nan, not a finite number")


# ---------------------------------------------------------------- deep chains


def test_a_chain_of_4000_fixed_joints_exits_2_with_one_line_not_a_crash(tmp_path):
    # Pinocchio's recursive parser crashes on it (exit 139, nothing printed): refused before Pinocchio sees it.
    # a subprocess: the test is about a crash
    result = run_process("base_link", "ee_link", "--robot", chain_urdf(tmp_path / "deep.urdf", 4000), timeout=120)
    assert result.returncode != -11
    assert_one_line_error(result, "link 'l4000' is 4000 joints below root 'l0'; manipkit loads trees up to 2000 joints deep")


def test_the_tip_of_a_1500_link_chain_is_ee_link(tmp_path):
    result = run_cli("tf-between", "base_link", "ee_link", "--robot", chain_urdf(tmp_path / "long.urdf", 1500), "--format", "json")
    assert result.returncode == 0, result.stderr
    # 1500 fixed joints of 1 mm each: the tip is 1.5 m above the root (l500 would be 0.5 m).
    assert json.loads(result.stdout)["translation"] == pytest.approx([0, 0, 1.5], abs=1e-9)
    text = run_cli("tf-between", "base_link", "ee_link", "--robot", tmp_path / "long.urdf").stdout
    assert "frame ee_link = l1500, the tip of the longest chain" in text


# ---------------------------------------------------------------- --q-file streams


def write_q_file(path: Path, poses, header=JOINTS) -> Path:
    path.write_text(",".join(header) + "\n" + "".join(",".join(map(repr, map(float, p))) + "\n" for p in poses))
    return path


def test_a_byte_order_mark_before_the_header_is_skipped(tmp_path):
    plain = write_q_file(tmp_path / "plain.csv", [POSE_A])
    excel = tmp_path / "excel.csv"  # Excel's "CSV UTF-8" starts with EF BB BF
    excel.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    result = run_cli("tf-between", "base_link", "ee_link", "--q-file", excel, "--format", "jsonl")
    assert result.returncode == 0, result.stderr
    assert np.abs(np.array(json.loads(result.stdout)["matrix"]) - course_arm_T_base_ee(POSE_A)).max() < 1e-12


def test_jsonl_gives_one_pose_a_line_as_the_json_document_gives_them(tmp_path):
    path = write_q_file(tmp_path / "q.csv", [POSE_A, POSE_B, (0,) * 5])
    result = run_cli("tf-between", "base_link", "ee_link", "--q-file", path, "--format", "jsonl")
    assert result.returncode == 0 and result.stderr == "", result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    assert lines == json.loads(run_cli("tf-between", "base_link", "ee_link", "--q-file", path, "--format", "json").stdout)["poses"]
    for line, pose in zip(lines, (POSE_A, POSE_B, (0,) * 5)):
        assert list(line) == ["q", "translation", "quaternion_xyzw", "rpy", "matrix"]
        assert line["q"] == dict(zip(JOINTS, map(float, pose)))
        assert np.abs(np.array(line["matrix"]) - course_arm_T_base_ee(pose)).max() < 1e-12


def test_jsonl_needs_a_q_file():
    assert_one_line_error(run_cli("tf-between", "base_link", "ee_link", "--format", "jsonl"), "--format jsonl needs --q-file")


def test_the_help_says_that_jsonl_streams():
    help_text = " ".join(run_cli("tf-between", "--help").stdout.split())
    assert "jsonl (JSON Lines: one pose a line)" in help_text and "only csv and jsonl can be read as they arrive" in help_text


def test_a_bad_row_after_the_first_batch_stops_the_output_there(tmp_path):
    rows = [POSE_A] * 10_000
    path = write_q_file(tmp_path / "q.csv", rows)
    with open(path, "a") as stream:
        stream.write("0,0,0,x,0\n")  # line 10002: header + 10,000 rows before it
    result = run_cli("tf-between", "base_link", "ee_link", "--q-file", path)
    assert_one_line_error(result, f"--q-file {path}: line 10002: joint 'elbow_joint': value 'x' is not a number")
    written = [line for line in result.stdout.splitlines() if not line.startswith(("#", "x,"))]
    assert 0 < len(written) < 10_000  # the batches before the bad one were written as they were computed


def test_an_error_in_the_first_rows_writes_nothing(tmp_path):
    path = write_q_file(tmp_path / "q.csv", [POSE_A, POSE_B])
    with open(path, "a") as stream:
        stream.write("1,2\n")
    result = run_cli("tf-between", "base_link", "ee_link", "--q-file", path, "--format", "json")
    assert_one_line_error(result, "line 4 has 2 values, the header has 5")
    assert result.stdout == ""


def peak_memory_kb(args, output: Path) -> tuple[int, int]:
    """(exit status, peak resident memory in kB) of ``tf-between ARGS > output``, measured in a child of a child.

    ``getrusage(RUSAGE_CHILDREN)`` in a fresh Python process sees only the one command it waited for.
    """
    script = ("import resource, subprocess, sys\n"
              "with open(sys.argv[1], 'w') as out:\n"
              "    status = subprocess.run(sys.argv[2:], stdout=out).returncode\n"
              "print(status, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n")
    result = subprocess.run([sys.executable, "-c", script, str(output), str(BIN / "tf-between"), *map(str, args)],
                            capture_output=True, text=True, timeout=600)
    status, peak = result.stdout.split()
    return int(status), int(peak)


def _q_file_poses(output_format: str, rows: int, folder: Path) -> tuple[int, np.ndarray, list[str]]:
    """(peak memory in kB, the joint rows, the pose lines) of ``tf-between --q-file`` on ``rows`` random rows."""
    Q = np.random.default_rng(15).uniform(-1.5, 1.5, size=(rows, 5))
    path = folder / f"q{rows}.csv"
    with open(path, "w") as stream:
        stream.write(",".join(JOINTS) + "\n")
        np.savetxt(stream, Q, delimiter=",", fmt="%.6f")
    output = folder / f"poses{rows}.{output_format}"
    status, peak_kb = peak_memory_kb(["base_link", "ee_link", "--q-file", path, "--format", output_format], output)
    assert status == 0
    with open(output) as stream:
        lines = [line for line in stream if not line.startswith(("#", "x,"))]
    assert len(lines) == rows
    return peak_kb, Q, lines


@pytest.mark.parametrize("output_format, rows", [("csv", CSV_ROWS), ("jsonl", JSONL_ROWS)])
def test_a_long_q_file_streams_in_bounded_memory(output_format, rows, tmp_path):
    # Reading the whole file first took 826 MB for 10^6 rows in CSV (about 0.6 kB a row above the process's
    # own 230 MB), and JSON passed 5 GB (about 5 kB a row). Streamed, the peak does not grow with the rows:
    # the long file peaks within MEMORY_GROWTH_LIMIT_KB of a short one (measured: CSV +2 MB from 12,500 to
    # 200,000 rows, JSON Lines +6 MB from 20,000 to 80,000), where reading it whole would add about 60 MB
    # (CSV, 10^5 rows) or 200 MB (JSON Lines, 4 x 10^4). Both runs cost a third of one of 10^6 rows.
    short_kb, _, _ = _q_file_poses(output_format, SHORT_ROWS, tmp_path)
    peak_kb, Q, lines = _q_file_poses(output_format, rows, tmp_path)
    assert peak_kb < PEAK_MEMORY_LIMIT_KB, f"peak {peak_kb / 1024:.0f} MB"
    assert peak_kb - short_kb < MEMORY_GROWTH_LIMIT_KB[output_format], f"{short_kb / 1024:.0f} MB, then {peak_kb / 1024:.0f} MB"
    for index in (0, len(Q) // 2, len(Q) - 1):  # spot checks against the independent chain of tests/reference.py
        q = np.round(Q[index], 6)
        if output_format == "csv":
            assert [float(v) for v in lines[index].split(",")[:3]] == pytest.approx(course_arm_T_base_ee(q)[:3, 3], abs=2e-6)
        else:
            assert np.abs(np.array(json.loads(lines[index])["matrix"]) - course_arm_T_base_ee(q)).max() < 1e-12


# --------------------------------------------------------------------------
# --compare with a 3x3 rotation (issue 14): rotations only, said so


def test_compare_with_a_3x3_rotation_compares_rotations_only(tmp_path):
    from manipkit.spatial.rotations import rot_z

    # course_arm at q = 0: T_base_ee is Rz(1.5708) (the URDF's rounded 90 deg), so its rotation block is
    # Rz(1.5708) exactly; the hand rotation written to 12 decimals agrees at 1e-9.
    hand = tmp_path / "R.txt"
    hand.write_text("\n".join(" ".join(f"{v:.12f}" for v in row) for row in rot_z(1.5708)) + "\n")
    result = run_cli("tf-between", "base_link", "ee_link", "--compare", hand, "--tol", "1e-9")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "a 3x3 rotation: comparing rotations only (the translation is not checked)" in result.stdout
    assert "the rotation AGREES with the model" in result.stdout
    data = json.loads(run_cli("tf-between", "base_link", "ee_link", "--compare", hand, "--tol", "1e-9", "--format", "json").stdout)
    assert data["compare"]["rotation_only"] is True and data["compare"]["position_error"] is None
    assert data["compare"]["agrees"] is True
    exact = tmp_path / "exact.txt"  # Rz(90 deg) exactly: 2.1e-4 deg off the model's 1.5708 rad
    exact.write_text("0 -1 0\n1 0 0\n0 0 1\n")
    result = run_cli("tf-between", "base_link", "ee_link", "--compare", exact)
    assert result.returncode == 1 and "the rotation DOES NOT AGREE with the model" in result.stdout
    assert "rotation error: 0.000210459 deg" in result.stdout


def test_the_command_line_starts_without_numpy_or_importlib_metadata():
    """``tf-between`` imports numpy itself, with OpenBLAS on one thread (``tf._import_numpy_with_one_blas_thread``),
    which only works if importing the command line has not loaded numpy already; and loading a bundled robot does
    not import ``importlib.metadata`` (about 50 ms). A fresh interpreter is the point: this one has both loaded."""
    code = ("import sys; import manipkit.app.cli, manipkit.app.cli.tf, manipkit.app.cli.common; "
            "print('numpy' in sys.modules); "
            "from manipkit.description.sources import example_robot_data_dir; example_robot_data_dir(); "
            "print('importlib.metadata' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "False"]
