"""``TrackNode``, the base of every node, and ``run_node``, the ``main`` of every executable.

A node subclass names itself (``DEFAULT_NAME``), lists its parameters (``PARAMS``) and, in its
``__init__``, creates its core object and its endpoints; the base does the rest:

- the standard constructor (``node_name``, ``context``, ``parameter_overrides``, ``cli_args``,
  as the launcher and the tests call it), then ``declare_params(PARAMS)`` into ``self.p``;
- ``main(argv)``: ``rclpy.init`` → build the node → spin until SIGINT/SIGTERM or shutdown →
  destroy (which closes files) → exit code. A bad parameter or bad input at start
  (``ValueError``, ``OSError``) prints one line on stderr and exits 2, without a traceback.

``python -m track_nodes <executable>`` (what the ``ros2 run`` shims call) looks the class up in
``track_nodes.registry`` and calls ``main``.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from typing import Any, ClassVar

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from track_nodes.base.params import Param, declare_params

EXIT_BAD_INPUT = 2


class TrackNode(Node):
    """A node of this package set: declared parameters in ``self.p``, endpoints in ``__init__``."""

    DEFAULT_NAME: ClassVar[str] = 'track_node'
    PARAMS: ClassVar[tuple[Param, ...]] = ()

    def __init__(self, *, node_name: str | None = None, context=None, parameter_overrides=None, cli_args=None,
                 **node_kwargs: Any) -> None:
        super().__init__(node_name or self.DEFAULT_NAME, context=context, parameter_overrides=parameter_overrides,
                         cli_args=cli_args, **node_kwargs)
        self.p = declare_params(self, self.PARAMS)

    @classmethod
    def main(cls, argv: Sequence[str] | None = None, **kwargs: Any) -> int:
        return run_node(cls, argv, **kwargs)


def run_node(factory: Callable[..., Node], argv: Sequence[str] | None = None, **kwargs: Any) -> int:
    """Run one node until shutdown; return the process exit code (0, or 2 for bad input)."""
    args = list(sys.argv if argv is None else argv)
    rclpy.init(args=args)
    try:
        node = factory(**kwargs)
    except (ValueError, OSError) as exc:
        name = getattr(factory, 'DEFAULT_NAME', getattr(factory, '__name__', 'node'))
        print(f'{name}: {exc}', file=sys.stderr)
        rclpy.try_shutdown()
        return EXIT_BAD_INPUT
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return getattr(node, 'exit_code', 0)
