"""manipkit.app.progress: the one progress mechanism (a callback the library calls, drawn here with tqdm)."""

from __future__ import annotations

import io

from manipkit.app.progress import progress_bar


def test_disabled_gives_no_callback():
    with progress_bar(False) as progress:
        assert progress is None


def test_a_bar_per_stage_on_stderr_and_nothing_left(monkeypatch):
    stderr = io.StringIO()
    monkeypatch.setattr("sys.stderr", stderr)
    with progress_bar(True) as progress:
        progress("FK samples", 0, 4)
        progress("FK samples", 3, 4)
        progress("IK", 1, 2)
        drawn = stderr.getvalue()
    assert "FK samples" in drawn and "0/4" in drawn and "IK" in drawn and "0/2" in drawn
    after = stderr.getvalue()[len(drawn):]
    assert after.strip(" \r\n\x1b[A") == ""  # transient: closing the bars only clears their lines


def test_auto_follows_whether_stderr_is_a_terminal(monkeypatch):
    monkeypatch.setattr("sys.stderr", io.StringIO())  # not a terminal
    with progress_bar(None) as progress:
        assert progress is None


def test_the_reach_map_build_reports_its_blocks(planar_2r):
    from manipkit.analysis.reachmap import build

    calls = []
    build(planar_2r, method="fk", voxel=0.2, orientations=1, samples=3000, block_samples=1000,
          progress=lambda stage, done, total: calls.append((stage, done, total)))
    assert calls == [("FK samples", d, 3) for d in range(4)]
