"""Command line of nld.

    nld scenes                                   built-in scenes, one per line
    nld show SCENE [--set KEY=VALUE ...]         resolved parameters with units
    nld simulate SCENE [--set ...] [--revs N | --t-end T] [--rtol R] [--samples-per-rev N]
                 [--ideal] [--out FILE.csv|FILE.parquet]
    nld poincare SCENE [--set ...] --transient N --revs M [--observables A,B] --out FILE
    nld bifurcation SCENE --param KEY --values START:STOP:COUNT [...] --out DIR [--resume] [--dask ADDR]
    nld spectrum SCENE [--set ...] [--observable NAME] [--out FILE]
    nld lyapunov SCENE [--set ...] [--transient N] [--revs M] [--json]
    nld chaos-map SCENE --x KEY --x-values A:B:N --y KEY --y-values A:B:N --out DIR [--resume]
    nld orbits SCENE [--set ...] [--period P] [--max-period P] [--transient N] [--json]
    nld continue SCENE --param KEY --values A:B:N [--period P] [--arclength | --natural]
                 [--out DIR] [--plot FILE]
    nld attractors SCENE [--set ...] [--starts N] [--transient N] [--revs M] [--json]
                 [--param KEY --values A:B:N --out DIR [--resume]] [--plot FILE]
    nld control SCENE [--set ...] [--method pyragas|edfc|ogy] [--signal NAME] [--body NAME]
                 [--gain K] [--memory R] [--delay S] [--target-period P] [--gains A:B:N] [--json]
    nld hard-cases [--quick] [--list] [NAME ...]  the integrators' hard regression cases
    nld study NAME [--quick] [--out-dir DIR]     run studies/NAME.py, print the PDF path
    nld --version

Exit status: 0 success, 1 failed integration or solve (the message on stderr; what was computed
is written beside --out as FILE.partial.SUFFIX, never over it) or standard output on a full disk
(one line), 2 bad input (one line ``nld: error: <message>`` on stderr, no traceback; a mechanism
that cannot be assembled included), 130 interrupted by Ctrl-C (SIGINT; one line ``nld:
interrupted: <what was kept>``: a simulate writes its partial table beside --out, a sweep, chaos
map or study keeps its finished points and resumes), 143 terminated by SIGTERM (the same, ``nld:
terminated by SIGTERM: <what was kept>``; the pool's workers end with the command), 141 when the
reader of stdout went away (``nld scenes | head -1``: no message, as ``yes | head -1``; 128 +
SIGPIPE, the status of a program killed by SIGPIPE).
``main(argv)`` returns the status instead of exiting, for tests.

Layout: the only package of nld that knows argparse. ``app`` assembles the parser from one module
per command (``scenes`` for scenes and show, ``simulate``, ``poincare``, ``bifurcation``,
``spectrum``, ``chaos_map``, ``lyapunov``, ``orbits`` for orbits and continue (``codim2`` for
continue's two-parameter curves, ``--follow``), ``attractors``,
``control``, ``hard_cases``, ``study``; each has ``add_parser(sub)`` and ``cmd_*(args)``, and
calls the library: the workflows live below, e.g. ``nld control`` is
:func:`nld.analysis.scene_control.control_scene`) and holds :func:`main`; ``args`` holds what they
share (the parser class with one-line errors, argument types, the scene and progress options, the
stderr messages).
Option defaults come from :mod:`nld.settings`, as the API's do.

Every command takes ``--quiet`` (no progress bars) and ``--progress`` (progress bars on stderr
even when it is not a terminal); by default long work shows a bar only on a terminal
(``nld.progress``).
"""
__all__ = ["main", "build_parser"]


def main(argv=None) -> int:
    """The command line (:func:`nld.cli.app.main`), its Ctrl-C handler installed before the
    commands' modules are imported: a Ctrl-C (or SIGTERM) while they load (numpy, pandas: seconds
    on a loaded machine) is one line and exit 128 + signal like any other, not a traceback."""
    from nld import interrupt
    interrupt.forget_received()
    try:
        interrupt.install()
        from nld.cli import app
        return app.main(argv)
    except KeyboardInterrupt:
        import signal
        import sys
        sig = interrupt.received() or signal.SIGINT
        head = "interrupted" if sig == signal.SIGINT else f"terminated by {signal.Signals(sig).name}"
        print(f"nld: {head}: nothing kept (the command had not started)", file=sys.stderr, flush=True)
        return 128 + int(sig)


def build_parser():
    """The parser of the whole command line (:func:`nld.cli.app.build_parser`)."""
    from nld.cli.app import build_parser as build
    return build()

if __name__ == "__main__":
    import sys
    sys.exit(main())
