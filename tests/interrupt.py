"""Kill a run after it has written some of its point files (for the resume tests)."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run_and_kill(code: str, out: Path, n_files: int = 2, timeout: float = 120.0) -> list[Path]:
    """Run ``python -c code`` (nld importable) and kill it once ``out`` holds ``n_files``
    ``point-*.parquet`` files (or it ended, or ``timeout`` s passed); returns the files written."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-c", code], env=env, cwd=ROOT)
    deadline = time.monotonic() + timeout
    try:
        while len(list(out.glob("point-*.parquet"))) < n_files and proc.poll() is None \
                and time.monotonic() < deadline:
            time.sleep(0.01)
    finally:
        proc.kill()
        proc.wait()
    return sorted(out.glob("point-*.parquet"))
