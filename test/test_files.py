"""rfidnav_common.files: a file is written whole or left as it was."""

from __future__ import annotations

from pathlib import Path

import pytest

from rfidnav_common.files import write_atomically

pytestmark = pytest.mark.tier("unit")


def test_a_write_that_fails_half_way_leaves_the_old_file_and_no_partial_one(tmp_path: Path,
                                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "summary.json"
    target.write_text("old")
    real_write = Path.write_text

    def disk_full_half_way(self: Path, text: str, *args, **kwargs) -> int:
        real_write(self, text[: len(text) // 2])
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Path, "write_text", disk_full_half_way)
    with pytest.raises(OSError, match="No space left"):
        write_atomically(target, "new text, longer than the old one")
    monkeypatch.undo()
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]


def test_a_write_replaces_the_file_whole(tmp_path: Path) -> None:
    target = tmp_path / "map.yaml"
    target.write_text("old")
    write_atomically(target, "new")
    assert target.read_text() == "new"
