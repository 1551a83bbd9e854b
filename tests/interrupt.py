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


def children(pid: int) -> list[int]:
    """The process ids whose parent is ``pid`` (Linux /proc; [] elsewhere)."""
    out = []
    for d in Path("/proc").glob("[0-9]*"):
        try:
            stat = (d / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if int(fields[1]) == pid:
            out.append(int(d.name))
    return out


def alive(pid: int) -> bool:
    """The process exists and is not a zombie."""
    try:
        stat = (Path("/proc") / str(pid) / "stat").read_text()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2] != "Z"


def _default_sigint():
    import signal
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def signal_when(argv, ready, cwd: Path, sig, *, env: dict | None = None, timeout: float = 120.0,
                workers: int = 0):
    """Run ``python -m nld argv`` in ``cwd``, send ``sig`` once ``ready(stderr_text)`` is true and
    (with ``workers``) that many child processes exist; returns (exit status, stdout, stderr,
    seconds from the signal to the exit, the child pids seen before the signal)."""
    import signal as _signal  # noqa: F401
    env = dict(os.environ if env is None else env)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env.pop("NLD_PROGRESS", None)
    err_path, out_path = cwd / "stderr.txt", cwd / "stdout.txt"
    with open(err_path, "w") as ferr, open(out_path, "w") as fout:
        # the child starts with the default SIGINT disposition whatever this process inherited
        # (a shell's background job ignores SIGINT, and Python keeps an ignored SIGINT ignored:
        # the command would never see the Ctrl-C the test sends)
        proc = subprocess.Popen([sys.executable, "-m", "nld", *argv], cwd=cwd, env=env,
                                stdout=fout, stderr=ferr, preexec_fn=_default_sigint)
        deadline = time.monotonic() + timeout
        kids: list[int] = []
        try:
            while proc.poll() is None:
                kids = children(proc.pid) if workers else []
                if len(kids) >= workers and ready(err_path.read_text()):
                    break
                assert time.monotonic() < deadline, "the command never got ready"
                time.sleep(0.05)
            assert proc.poll() is None, f"the command ended before the signal: {err_path.read_text()}"
            t0 = time.monotonic()
            proc.send_signal(sig)
            rc = proc.wait(timeout=60)
            dt = time.monotonic() - t0
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    return rc, out_path.read_text(), err_path.read_text(), dt, kids
