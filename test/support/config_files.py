"""Private copies of the shipped config files, for tests that break one thing in them."""

from __future__ import annotations

import shutil
from pathlib import Path

from support.runs import WORKSPACE

CONFIG = WORKSPACE / "config"


def copy_config(tmp_path: Path, referenced: tuple[str, ...]) -> Path:
    """A private copy of the config files a scenario uses (paths relative to config/), for breaking."""
    root = tmp_path / "config"
    for relative in referenced:
        (root / relative).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(CONFIG / relative, root / relative)
    return root


def edit(path: Path, old: str, new: str) -> None:
    """Replace ``old`` once; fail loudly if the shipped file no longer contains it (the case would test nothing)."""
    text = path.read_text()
    assert text.count(old) == 1, f"{path.name}: expected exactly one {old!r}"
    path.write_text(text.replace(old, new))
