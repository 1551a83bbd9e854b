"""Provenance of results: nld version, git hash, time."""
from __future__ import annotations

import functools
import os
import subprocess
from pathlib import Path


@functools.lru_cache(maxsize=1)
def git_hash() -> str:
    """Git commit of the nld source tree (with '+dirty' when it has uncommitted changes), or 'unknown'.

    A copy of the tree on a batch machine may name its commit in the environment variable
    NLD_GIT_HASH; when set it takes precedence (such a copy's own .git, if any, may be stale) and is
    reported as '<hash> (NLD_GIT_HASH)'."""
    if os.environ.get("NLD_GIT_HASH", "").strip():
        return _from_env()
    root = Path(__file__).resolve().parents[2]
    try:
        h = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True,
                           timeout=5).stdout.strip()
        if not h:
            return _from_env()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                               capture_output=True, text=True, timeout=5).stdout.strip()
        return h + ("+dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return _from_env()


def _from_env() -> str:
    h = os.environ.get("NLD_GIT_HASH", "").strip()
    return f"{h} (NLD_GIT_HASH)" if h else "unknown"
