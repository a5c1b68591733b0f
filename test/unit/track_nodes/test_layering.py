"""The node layer's import rules (docs/DESIGN.md, "Four layers; imports point down only").

- No node module imports another node module (a node is an adapter over the core; what two nodes
  share lives in track_core, track_msgs_py or a non-node module such as ``track_nodes.base``).
- No import cycle exists anywhere in ``src/``, function-level imports included (they hide cycles
  from the interpreter but not from a reader).
- track_msgs_py never imports track_nodes; no library package imports track_experiments (the
  experiments and benches sit above the nodes; node defaults come from core profiles).
- No module of ``track_nodes.bag`` or ``track_nodes.report`` imports ``track_nodes.launch``: bags and
  reports are read and written without the launcher (what they share with it lives in ``base``).

The import graph is read from the source with ``ast``: every ``import``/``from … import``
statement at any depth, resolved to the modules that exist in the tree.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from track_nodes.registry import NODES

SRC = Path(__file__).resolve().parents[3] / 'src'
PACKAGES = ('track_core', 'track_msgs_py', 'track_nodes', 'track_experiments')


def module_files(src: Path = SRC) -> dict[str, Path]:
    """Dotted module name → file, for every module of the three packages under ``src``."""
    out = {}
    for pkg in PACKAGES:
        root = src / pkg / pkg
        for path in root.rglob('*.py'):
            rel = path.relative_to(root.parent).with_suffix('')
            parts = rel.parts[:-1] if rel.name == '__init__' else rel.parts
            out['.'.join(parts)] = path
    return out


def import_graph(files: dict[str, Path]) -> dict[str, set[str]]:
    """Module → the modules of ``files`` that it imports (any depth, resolved to existing modules)."""
    graph: dict[str, set[str]] = {}
    for mod, path in files.items():
        is_pkg = path.name == '__init__.py'
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ''
                if node.level:
                    anchor = mod.split('.') if is_pkg else mod.split('.')[:-1]
                    anchor = anchor[:len(anchor) - (node.level - 1)]
                    base = '.'.join([*anchor, base] if base else anchor)
                targets = [f'{base}.{a.name}' if f'{base}.{a.name}' in files else base for a in node.names]
            for name in targets:
                target = name
                while target and target not in files:  # `import a.b.c` names a.b.c; a name inside a module
                    target = target.rpartition('.')[0]
                if target and target != mod:
                    deps.add(target)
        graph[mod] = deps
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for root, deps in graph.items():
        if root in index:
            continue
        work = [(root, iter(sorted(deps)))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def node_modules() -> set[str]:
    return {target.partition(':')[0] for target in NODES.values()}


def node_to_node_imports(graph: dict[str, set[str]], nodes: set[str]) -> list[str]:
    return sorted(f'{a} -> {b}' for a in nodes for b in graph.get(a, ()) if b in nodes and b != a)


@pytest.fixture(scope='module')
def graph() -> dict[str, set[str]]:
    return import_graph(module_files())


def test_the_graph_sees_the_real_imports(graph):
    assert 'track_nodes.base.params' in graph['track_nodes.base.node']
    assert 'track_core.demo' in graph['track_nodes.demo.demo_tracker']
    assert len(node_modules()) >= 14 and node_modules() <= set(graph)


def test_no_node_module_imports_another(graph):
    assert not node_to_node_imports(graph, node_modules())


def test_no_import_cycle_in_src(graph):
    assert not cycles(graph)


def test_track_msgs_py_never_imports_track_nodes(graph):
    bad = sorted(f'{a} -> {b}' for a, deps in graph.items() if a.startswith('track_msgs_py')
                 for b in deps if b.startswith('track_nodes'))
    assert not bad


BELOW_THE_LAUNCHER = ('track_nodes.bag', 'track_nodes.report')


def _in(module: str, packages: tuple[str, ...]) -> bool:
    return any(module == p or module.startswith(f'{p}.') for p in packages)


def launcher_imports(graph: dict[str, set[str]]) -> list[str]:
    """Imports of ``track_nodes.launch`` by a module of ``BELOW_THE_LAUNCHER`` (at any depth of the module)."""
    return sorted(f'{a} -> {b}' for a, deps in graph.items() if _in(a, BELOW_THE_LAUNCHER)
                  for b in deps if _in(b, ('track_nodes.launch',)))


def test_no_bag_or_report_module_imports_the_launcher(graph):
    assert 'track_nodes.bag.dataset' in graph and 'track_nodes.report.maritime_sim' in graph
    assert not launcher_imports(graph)


# --- the rules can fail ------------------------------------------------------------------------------

def _tree(tmp_path: Path, files: dict[str, str]) -> dict[str, set[str]]:
    for rel, text in files.items():
        path = tmp_path / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return import_graph(module_files(tmp_path))


def test_a_function_level_cycle_is_found(tmp_path):
    g = _tree(tmp_path, {
        'track_nodes/track_nodes/__init__.py': '',
        'track_nodes/track_nodes/a.py': 'from track_nodes.b import f\n',
        'track_nodes/track_nodes/b.py': 'def f():\n    from track_nodes import a\n',
        'track_nodes/track_nodes/c.py': 'from . import a\n',
    })
    assert cycles(g) == [['track_nodes.a', 'track_nodes.b']]
    assert g['track_nodes.c'] == {'track_nodes.a'}


def test_a_node_to_node_import_is_found(tmp_path):
    g = _tree(tmp_path, {
        'track_nodes/track_nodes/__init__.py': '',
        'track_nodes/track_nodes/x/__init__.py': '',
        'track_nodes/track_nodes/x/one.py': 'from track_nodes.x.two import HELPER\n',
        'track_nodes/track_nodes/x/two.py': 'HELPER = 1\n',
    })
    assert node_to_node_imports(g, {'track_nodes.x.one', 'track_nodes.x.two'}) == [
        'track_nodes.x.one -> track_nodes.x.two']


def test_a_report_importing_the_launcher_is_found(tmp_path):
    g = _tree(tmp_path, {
        'track_nodes/track_nodes/__init__.py': '',
        'track_nodes/track_nodes/launch/__init__.py': '',
        'track_nodes/track_nodes/launch/scenario.py': 'X = 1\n',
        'track_nodes/track_nodes/report/__init__.py': '',
        'track_nodes/track_nodes/report/sim.py': 'def f():\n    from track_nodes.launch.scenario import X\n',
        'track_nodes/track_nodes/reporting.py': 'from track_nodes.launch import scenario\n',  # not under report/
    })
    assert launcher_imports(g) == ['track_nodes.report.sim -> track_nodes.launch.scenario']


def test_no_library_package_imports_the_experiments(graph):
    bad = sorted(f'{a} -> {b}' for a, deps in graph.items() if not a.startswith('track_experiments')
                 for b in deps if b.startswith('track_experiments'))
    assert 'track_experiments.cli' in graph and not bad
