"""``python -m track_nodes <executable> [--ros-args ...]``: run one executable (what the shims call)."""

import sys

from track_nodes.registry import UnknownExecutableError, executables, main_of


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0].startswith('-'):
        print(f'usage: python -m track_nodes EXECUTABLE [args]; executables: {", ".join(executables())}',
              file=sys.stderr)
        return 2
    try:
        entry = main_of(args[0])  # imports the node's module (numpy, scipy, rclpy: seconds on a busy machine)
        return entry([args[0], *args[1:]])
    except UnknownExecutableError:
        print(f'track_nodes: unknown executable {args[0]!r}; known: {", ".join(executables())}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # Ctrl-C before rclpy took over SIGINT (still importing): no traceback
        return 130


if __name__ == '__main__':
    raise SystemExit(main())
