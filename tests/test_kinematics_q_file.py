"""manipkit.kinematics.q_file: joint vectors from a CSV file, checked against values written by hand."""

import math

import numpy as np
import pytest

import manipkit
from manipkit.errors import JointLimitError, JointValueError
from manipkit.kinematics.q_file import joint_limits_error, read_q_file

COURSE = ("arm_base_joint", "shoulder_joint", "bottom_wrist_joint", "elbow_joint", "top_wrist_joint")


@pytest.fixture(scope="module")
def course_arm():
    return manipkit.load("course_arm")


@pytest.fixture(scope="module")
def iiwa():
    return manipkit.load("iiwa14")  # limits +-170, 120, 170, 120, 170, 120, 175 degrees


@pytest.fixture(scope="module")
def scara():
    return manipkit.load("scara")  # joint3 is prismatic, limits [0, 0.3] m


def write(tmp_path, text, name="q.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_rows_follow_the_joint_order_whatever_the_column_order(course_arm, tmp_path):
    assert course_arm.joint_names == COURSE
    path = write(tmp_path, "elbow_joint,arm_base_joint\n0.5,-0.25\n1,2\n")
    Q = read_q_file(course_arm, path)
    # Columns elbow (index 3) and arm_base (index 0); the other joints are 0.
    assert Q.tolist() == [[-0.25, 0, 0, 0.5, 0], [2, 0, 0, 1, 0]]
    assert Q.tolist() == [course_arm.q(elbow_joint=0.5, arm_base_joint=-0.25).tolist(),
                          course_arm.q(elbow_joint=1, arm_base_joint=2).tolist()]


def test_comments_blank_lines_and_spaces_are_skipped(course_arm, tmp_path):
    path = write(tmp_path, "# poses of the homework\n\n elbow_joint , shoulder_joint\n# first\n0.1 , 0.2\n\n,\n0.3,0.4\n")
    assert read_q_file(course_arm, path).tolist() == [[0, 0.2, 0, 0.1, 0], [0, 0.4, 0, 0.3, 0]]


def test_degrees_turn_angles_into_radians_and_leave_metres(scara, tmp_path):
    path = write(tmp_path, "joint1,joint3\n90,0.2\n-45,0.1\n")
    Q = read_q_file(scara, path, degrees=True)
    # pi/2 and -pi/4 rad for the revolute joint1; joint3 (prismatic) keeps 0.2 and 0.1 m.
    assert Q[:, 0] == pytest.approx([math.pi / 2, -math.pi / 4], abs=1e-15)
    assert Q[:, 2].tolist() == [0.2, 0.1]
    assert Q[:, [1, 3]].tolist() == [[0, 0], [0, 0]]


def test_values_outside_the_limits_are_kept_by_default(iiwa, tmp_path):
    path = write(tmp_path, "iiwa_joint_2\n2.5\n")
    assert read_q_file(iiwa, path)[0, 1] == 2.5


def test_limits_error_names_the_line_and_the_limits(iiwa, tmp_path):
    path = write(tmp_path, "iiwa_joint_2,iiwa_joint_4\n0.1,0.2\n# a comment line\n2.5,0\n")
    with pytest.raises(JointLimitError) as caught:
        read_q_file(iiwa, path, limits="error")
    # 120 deg = 2.0944 rad; the comment is line 3, so the bad row is line 4.
    assert str(caught.value) == (f"{path}: line 4: joint 'iiwa_joint_2' = 2.5 is above its upper limit 2.0944 "
                                 "(limits [-2.0944, 2.0944] rad)")
    assert (caught.value.joint, caught.value.value, caught.value.unit) == ("iiwa_joint_2", 2.5, "rad")
    assert caught.value.upper == pytest.approx(math.radians(120), abs=1e-12)


def test_limits_error_in_degrees_speaks_degrees_and_names_the_other_joints(iiwa, tmp_path):
    path = write(tmp_path, "iiwa_joint_2,iiwa_joint_4,iiwa_joint_6\n150,-130,121\n")
    with pytest.raises(JointLimitError) as caught:
        read_q_file(iiwa, path, degrees=True, limits="error")
    assert str(caught.value) == (f"{path}: line 2: joint 'iiwa_joint_2' = 150 is above its upper limit 120 "
                                 "(limits [-120, 120] deg); also outside: iiwa_joint_4, iiwa_joint_6")
    assert caught.value.value == pytest.approx(math.radians(150), abs=1e-12) and caught.value.unit == "rad"


def test_limits_clamp_moves_values_to_the_limits_with_one_warning(iiwa, tmp_path):
    path = write(tmp_path, "iiwa_joint_2,iiwa_joint_7\n2.5,0\n0.1,-4\n-3,4\n0,0\n")
    with pytest.warns(UserWarning) as caught:
        Q = read_q_file(iiwa, path, limits="clamp")
    assert len(caught) == 1
    assert str(caught[0].message) == (f"{path}: clamped 4 value(s) into the joint limits "
                                      "(line 2 iiwa_joint_2, line 3 iiwa_joint_7, line 4 iiwa_joint_2, ...)")
    j2, j7 = math.radians(120), math.radians(175)
    assert Q[:, 1] == pytest.approx([j2, 0.1, -j2, 0], abs=1e-12)
    assert Q[:, 6] == pytest.approx([0, -j7, j7, 0], abs=1e-12)


def test_unknown_column_suggests_the_closest_joint(course_arm, tmp_path):
    path = write(tmp_path, "elbw_joint\n0.1\n")
    with pytest.raises(JointValueError, match=r"q.csv: unknown joint column\(s\) elbw_joint; did you mean elbow_joint\? joints: arm_base_joint"):
        read_q_file(course_arm, path)


def test_repeated_column_is_an_error(course_arm, tmp_path):
    path = write(tmp_path, "elbow_joint,elbow_joint\n0.1,0.2\n")
    with pytest.raises(JointValueError, match=r"column\(s\) elbow_joint appear twice in the header"):
        read_q_file(course_arm, path)


def test_short_row_names_its_line(course_arm, tmp_path):
    path = write(tmp_path, "elbow_joint,shoulder_joint\n0.1,0.2\n0.3\n")
    with pytest.raises(JointValueError, match="line 3 has 1 values, the header has 2"):
        read_q_file(course_arm, path)


def test_bad_cell_names_the_line_and_the_joint(course_arm, tmp_path):
    path = write(tmp_path, "elbow_joint\n0.1\nx\n")
    with pytest.raises(JointValueError, match="q.csv: line 3: joint 'elbow_joint': value 'x' is not a number"):
        read_q_file(course_arm, path)


def test_non_finite_cell_is_an_error(course_arm, tmp_path):
    path = write(tmp_path, "elbow_joint\nnan\n")
    with pytest.raises(JointValueError, match="line 2: joint 'elbow_joint': value nan is not finite"):
        read_q_file(course_arm, path)


def test_header_without_rows_is_an_error(course_arm, tmp_path):
    path = write(tmp_path, "# only a header\nelbow_joint\n")
    with pytest.raises(JointValueError, match="needs a header of joint names and at least one row"):
        read_q_file(course_arm, path)


def test_missing_file_folder_and_binary_file_are_errors(course_arm, tmp_path):
    with pytest.raises(JointValueError, match=r"nothere.csv: cannot read \(No such file or directory\)"):
        read_q_file(course_arm, tmp_path / "nothere.csv")
    with pytest.raises(JointValueError, match="is a folder, expected a CSV file"):
        read_q_file(course_arm, tmp_path)
    binary = tmp_path / "q.bin"
    binary.write_bytes(b"\xff\xfe\x00\x81" * 10)
    with pytest.raises(JointValueError, match="not a text file; expected CSV with a header of joint names"):
        read_q_file(course_arm, binary)


def test_unknown_limits_policy_is_an_error(course_arm, tmp_path):
    path = write(tmp_path, "elbow_joint\n0.1\n")
    with pytest.raises(JointValueError, match="limits='strict': choose one of ignore, error, clamp"):
        read_q_file(course_arm, path, limits="strict")


def test_joint_limits_error_lists_at_most_three_more_joints():
    violations = [JointLimitError(f"j{i}", 2.0, -1.0, 1.0) for i in range(6)]
    error = joint_limits_error(violations, prefix="here: ")
    assert str(error) == "here: joint 'j0' = 2 is above its upper limit 1 (limits [-1, 1] rad); also outside: j1, j2, j3, ..."
    assert (error.joint, error.value, error.lower, error.upper, error.unit) == ("j0", 2.0, -1.0, 1.0, "rad")


def test_joint_limits_error_keeps_metres_in_metres_with_degrees():
    error = joint_limits_error([JointLimitError("slide", 0.5, 0.0, 0.3, unit="m")], degrees=True)
    assert str(error) == "joint 'slide' = 0.5 is above its upper limit 0.3 (limits [0, 0.3] m)"


def test_result_is_a_float_array_of_the_robots_width(course_arm, tmp_path):
    Q = read_q_file(course_arm, write(tmp_path, "elbow_joint\n1\n"))
    assert Q.dtype == np.float64 and Q.shape == (1, 5)


# ---------------------------------------------------------------- issue 15: streaming, BOM, files that are not files


def test_a_utf8_byte_order_mark_is_skipped(course_arm, tmp_path):
    path = tmp_path / "excel.csv"
    path.write_bytes(b"\xef\xbb\xbfelbow_joint,shoulder_joint\r\n0.5,0.25\r\n")  # Excel's "CSV UTF-8"
    assert read_q_file(course_arm, path).tolist() == [[0, 0.25, 0, 0.5, 0]]


def test_rows_stream_in_batches_in_file_order(course_arm, tmp_path):
    from manipkit.kinematics.q_file import iter_q_file

    values = np.arange(25 * 2, dtype=float).reshape(25, 2) / 100
    path = write(tmp_path, "elbow_joint,shoulder_joint\n" + "".join(f"{a!r},{b!r}\n" for a, b in values.tolist()))
    batches = list(iter_q_file(course_arm, path, batch_rows=10))
    assert [len(batch) for batch in batches] == [10, 10, 5]
    Q = np.concatenate(batches)
    assert Q[:, 3].tolist() == values[:, 0].tolist() and Q[:, 1].tolist() == values[:, 1].tolist()
    assert Q[:, [0, 2, 4]].tolist() == [[0, 0, 0]] * 25


def test_a_bad_row_is_raised_when_its_batch_is_reached(course_arm, tmp_path):
    from manipkit.kinematics.q_file import iter_q_file

    path = write(tmp_path, "elbow_joint\n" + "0.1\n" * 12 + "x\n")  # the bad row is line 14
    batches = iter_q_file(course_arm, path, batch_rows=5)
    assert len(next(batches)) == 5 and len(next(batches)) == 5
    with pytest.raises(JointValueError, match="q.csv: line 14: joint 'elbow_joint': value 'x' is not a number"):
        next(batches)


def test_whole_batches_give_what_row_by_row_robot_q_gives(iiwa, tmp_path):
    # Degrees, columns out of order, values outside the limits clamped: the batch path against Robot.q and
    # Robot.clamp a row at a time (the definition of each row's value).
    rng = np.random.default_rng(7)
    header = ["iiwa_joint_4", "iiwa_joint_1", "iiwa_joint_2"]
    values = rng.uniform(-180, 180, size=(300, 3))
    path = write(tmp_path, ",".join(header) + "\n" + "".join(",".join(map(repr, row)) + "\n" for row in values.tolist()))
    with pytest.warns(UserWarning) as caught:
        Q = read_q_file(iiwa, path, degrees=True, limits="clamp")
    expected = np.array([iiwa.clamp(iiwa.q(dict(zip(header, row)), degrees=True)) for row in values])
    assert np.array_equal(Q, expected)
    outside = [f"line {line} {error.joint}" for line, row in enumerate(values, start=2)
               for error in iiwa.limit_violations(iiwa.q(dict(zip(header, row)), degrees=True))]
    assert len(caught) == 1 and str(caught[0].message) == (f"{path}: clamped {len(outside)} value(s) into the joint "
                                                           f"limits ({', '.join(outside[:3])}, ...)")


def test_clamp_warning_counts_every_batch_and_names_the_first_three(iiwa, tmp_path):
    from manipkit.kinematics.q_file import iter_q_file

    path = write(tmp_path, "iiwa_joint_2\n" + "0\n2.5\n" * 6)  # 6 values above 2.0944 rad on lines 3, 5, 7, ...
    with pytest.warns(UserWarning) as caught:
        Q = np.concatenate(list(iter_q_file(iiwa, path, limits="clamp", batch_rows=2)))
    assert str(caught[0].message) == (f"{path}: clamped 6 value(s) into the joint limits "
                                      "(line 3 iiwa_joint_2, line 5 iiwa_joint_2, line 7 iiwa_joint_2, ...)")
    assert Q[1::2, 1] == pytest.approx([math.radians(120)] * 6, abs=1e-12)


def test_a_line_longer_than_the_limit_is_refused_without_being_held(course_arm, tmp_path):
    from manipkit.kinematics.q_file import MAX_LINE_CHARS

    path = write(tmp_path, "elbow_joint\n0.1\n" + "1" * (MAX_LINE_CHARS + 1) + "\n")
    with pytest.raises(JointValueError, match="q.csv: line 3 is longer than 65536 characters"):
        read_q_file(course_arm, path)


def test_a_device_is_refused_before_reading(course_arm):
    from manipkit.errors import InputFileError

    with pytest.raises(InputFileError, match="joint-value file /dev/null is a character device, not a regular file"):
        read_q_file(course_arm, "/dev/null")


def test_a_wide_row_is_refused_as_it_is_read_not_a_batch_later(course_arm, tmp_path):
    # 100 rows of 21,000 values: the first such row is the error (before, a whole batch was held as strings)
    header = ",".join(course_arm.joint_names)
    path = tmp_path / "wide.csv"
    path.write_text(header + "\n" + ("0," * 21000 + "0\n") * 100)
    with pytest.raises(JointValueError, match="wide.csv: line 2 has 21001 values, the header has 5"):
        read_q_file(course_arm, path)


def test_a_quoted_value_running_over_many_lines_is_bounded(course_arm, tmp_path):
    # an unclosed quote makes csv gather every following line into one record: refused after MAX_LINE_CHARS
    path = tmp_path / "quoted.csv"
    path.write_text(",".join(course_arm.joint_names) + '\n"' + ("x" * 1000 + "\n") * 500)
    with pytest.raises(JointValueError, match="quoted.csv: line 67 ends a row \\(a quote left open\\?\\) that is longer than 65536"):
        read_q_file(course_arm, path)
