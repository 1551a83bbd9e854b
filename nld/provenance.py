"""Provenance of results: nld version, git hash, time."""
from __future__ import annotations

import functools
import subprocess
from pathlib import Path


@functools.lru_cache(maxsize=1)
def git_hash() -> str:
    """Git commit of the nld source tree (with '+dirty' when it has uncommitted changes), or 'unknown'."""
    root = Path(__file__).resolve().parent.parent
    try:
        h = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True,
                           timeout=5).stdout.strip()
        if not h:
            return "unknown"
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                               capture_output=True, text=True, timeout=5).stdout.strip()
        return h + ("+dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"
