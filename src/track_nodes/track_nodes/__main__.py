"""``python -m track_nodes <executable> [--ros-args ...]``: run one executable (what the shims call)."""

import contextlib
import sys

PARENT_ENV = 'TRACK_STOP_WITH_PARENT'  # a launcher's pid: this process gets SIGINT when that process dies


def stop_with_parent() -> None:
    """Linux: ask for SIGINT when the launcher that started this process dies (``prctl(PR_SET_PDEATHSIG)``),
    so a launcher killed with SIGKILL leaves no node running and the recorder still closes its bag. The
    launcher names itself in ``TRACK_STOP_WITH_PARENT``; if it is already gone, the stop comes at once."""
    import os

    parent = os.environ.pop(PARENT_ENV, '')
    if not parent.isdigit() or not sys.platform.startswith('linux'):
        return
    import ctypes
    import signal

    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGINT))  # 1: PR_SET_PDEATHSIG
    if os.getppid() != int(parent):  # it died before the request took effect (or another started us)
        os.kill(os.getpid(), signal.SIGINT)


def main(argv: list[str] | None = None) -> int:
    """Run the executable named first in ``argv``; its exit code (130: Ctrl-C before rclpy took SIGINT)."""
    args = list(sys.argv[1:] if argv is None else argv)
    try:
        stop_with_parent()
        # Imported here, inside the guard: on a busy machine they take seconds, and a Ctrl-C then is a stop.
        from track_nodes.base.usage import HELP_FLAGS, cached_help
        from track_nodes.registry import UnknownExecutableError, executables
    except KeyboardInterrupt:
        return 130
    if not args or args[0].startswith('-'):
        print(f'usage: python -m track_nodes EXECUTABLE [args]; executables: {", ".join(executables())}',
              file=sys.stderr)
        return 2
    # "EXE --help": printed before with these sources, it is printed again without importing the node,
    # rclpy or the core (base/usage.py); else it is made, printed and kept below.
    plain_help = len(args) == 2 and args[1] in HELP_FLAGS and args[0] in executables()
    if plain_help and (text := cached_help(args)) is not None:
        sys.stdout.write(text)
        return 0
    try:
        return _run(args, plain_help)
    except UnknownExecutableError:
        print(f'track_nodes: unknown executable {args[0]!r}; known: {", ".join(executables())}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # Ctrl-C before rclpy took over SIGINT (still importing): no traceback; or
        return 0 if _torn_down() else 130  # one that outran the hold of a finished teardown (base/signals.py)


def _run(args: list[str], plain_help: bool) -> int:
    """The executable ``args[0]`` with its arguments; ``plain_help``: just ``EXE --help``, whose text is kept."""
    from track_nodes.base.usage import remember_help, wants_help
    from track_nodes.registry import LIFECYCLE, MAINS, NODES, main_of, node_class

    node = (args[0] in NODES or args[0] in LIFECYCLE) and args[0] not in MAINS
    if node and wants_help(args):  # a node asked for help never starts
        from track_nodes.base.usage import usage
        text = usage(args[0], node_class(args[0])) + '\n'
        sys.stdout.write(text)
        if plain_help:
            remember_help(args, text)
        return 0
    entry = main_of(args[0])  # imports the node's module (numpy, scipy, rclpy: seconds on a busy machine)
    if plain_help:  # a tool's own argparse usage (recorder, player, node_group, ...): kept as printed
        return _help_of(entry, args, remember_help)
    return entry([args[0], *args[1:]])


def _help_of(entry, args: list[str], remember) -> int:
    """Run ``entry`` for its ``--help`` (argparse prints, then exits 0), print the text and keep it."""
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        try:
            code = entry(list(args))
        except SystemExit as exc:
            code = exc.code
    text = out.getvalue()
    sys.stdout.write(text)
    if code in (0, None) and text:
        remember(args, text)
    return code or 0


def _torn_down() -> bool:
    """The nodes of this process were torn down (files closed, DDS participant deleted): base/teardown.py."""
    teardown = sys.modules.get('track_nodes.base.teardown')
    return bool(getattr(getattr(teardown, 'TEARDOWN', None), 'done', False))


def _exit(code: int) -> None:
    """Leave a node process without CPython's module finalization, once the nodes are torn down.

    After ``run_nodes`` the nodes are destroyed (files closed, the DDS participant deleted, its peers
    told) and rclpy is shut down; CPython's finalization then only frees the modules (numpy, scipy,
    rclpy): about 0.4 s of CPU per process. At a ``--processes`` stop every node does it at once (25
    processes for idsq) on a shared machine: it took over 10 s of wall time, and the launcher killed
    the last ones as hung. Any other program (bag tools) exits the normal way, and so does a Ctrl-C
    while importing: nothing is imported here then (a half-imported module would raise again).
    """
    if not _torn_down():
        raise SystemExit(code)
    import logging
    import os

    logging.shutdown()  # the one exit handler a node process registers (logging's); os._exit skips them all
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(code if isinstance(code, int) else 1)


if __name__ == '__main__':
    _exit(main())
