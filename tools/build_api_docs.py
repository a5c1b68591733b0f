"""Build the API reference (HTML, pdoc) of track_core, track_msgs_py and track_nodes into build/api/.

    .venv/bin/python tools/build_api_docs.py            # build/api/index.html
    .venv/bin/python tools/build_api_docs.py --out DIR track_core   # one package

A package page documents what the package's ``__init__`` exports (its ``__all__``), which is the
public API; docstrings are read as reStructuredText (``literal``, :func:`name`), as written.
Exits 1 on any warning, each printed: pdoc's own (a module that does not import, an annotation it
cannot resolve, an ``__all__`` name that does not exist) and a role reference (:func:`name`,
:class:`.Name`, :mod:`.module`) in a rendered docstring that names nothing, a check pdoc lacks
(it renders such a reference as plain code). Why pdoc and not Sphinx: docs/API.md.
"""

from __future__ import annotations

import argparse
import importlib
import re
import sys
import warnings
from pathlib import Path

import pdoc
import pdoc.doc
import pdoc.extract
import pdoc.render

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ('track_core', 'track_msgs_py', 'track_nodes')
ROLE = re.compile(r'(?::py)?:(?:mod|func|data|const|class|meth|attr|exc|obj):`~?([^`]+)`')


def _walk(obj, parts: list[str]) -> bool:
    """Whether ``obj.a.b`` exists, importing a submodule where a package lacks the attribute."""
    for part in parts:
        if not hasattr(obj, part) and hasattr(obj, '__path__'):
            try:
                importlib.import_module(f'{obj.__name__}.{part}')
            except ImportError:
                return False
        if not hasattr(obj, part):
            return False
        obj = getattr(obj, part)
    return True


def _absolute(dotted: str) -> bool:
    """Whether ``pkg.module.Name.attr`` exists."""
    head, *rest = dotted.split('.')
    try:
        return _walk(importlib.import_module(head), rest)
    except ImportError:
        return False


def resolves(target: str, doc: pdoc.doc.Doc) -> bool:
    """Whether a role target resolves where its docstring was written (``doc.taken_from``)."""
    target = target.removesuffix('()')
    modname, qualname = doc.taken_from
    module = importlib.import_module(modname)
    if target.startswith('.'):  # relative to the package, as pdoc and Sphinx read it
        base = modname if hasattr(module, '__path__') else modname.rpartition('.')[0]
        while target.startswith('..'):
            target, base = target[1:], base.rpartition('.')[0]
        return _absolute(base + target)
    scopes = [module]
    enclosing = qualname.split('.') if isinstance(doc, pdoc.doc.Class) else qualname.split('.')[:-1]
    for part in enclosing:  # the class itself, or the classes enclosing a method or an attribute
        scopes.append(getattr(scopes[-1], part, None))
    return any(_walk(scope, target.split('.')) for scope in scopes if scope is not None) or _absolute(target)


def _docs(module: pdoc.doc.Module):
    """The module and every documented member, recursively (what a page renders)."""
    yield module
    for member in module.members.values():
        if isinstance(member, pdoc.doc.Class):
            yield member
            yield from member.members.values()
        else:
            yield member


def _own_docstring(doc: pdoc.doc.Doc) -> str:
    """The docstring written on the object itself (pdoc shows a parent's, rclpy's ``Node.__init__``, if none)."""
    if isinstance(doc, pdoc.doc.Function | pdoc.doc.Class):
        return getattr(doc.obj, '__doc__', None) or ''
    return doc.docstring or ''


def reference_problems(modules: dict[str, pdoc.doc.Module], packages) -> list[str]:
    """Role references that name nothing, in the docstrings written in ``packages`` (not inherited ones)."""
    problems = []
    for module in modules.values():
        for doc in _docs(module):
            if doc.taken_from[0].split('.')[0] not in packages:
                continue
            for target in ROLE.findall(_own_docstring(doc)):
                if not resolves(target, doc):
                    problems.append(f'{doc.fullname}: reference {target!r} names nothing')
    return sorted(set(problems))


def build(out: Path, packages=PACKAGES) -> list[str]:
    """Render ``packages`` into ``out``; every warning as a line (empty: a clean build)."""
    pdoc.render.configure(docformat='restructuredtext', footer_text='tracking package set')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        pdoc.pdoc(*packages, output_directory=out)
        names = pdoc.extract.walk_specs(list(packages))
        modules = {name: pdoc.doc.Module.from_name(name) for name in names}
    found = [f'{w.category.__name__}: {w.message}' for w in caught]
    return found + reference_problems(modules, packages)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--out', type=Path, default=ROOT / 'build/api', help='output directory (default build/api)')
    ap.add_argument('packages', nargs='*', default=list(PACKAGES), help=f'default: {" ".join(PACKAGES)}')
    args = ap.parse_args(argv)
    problems = build(args.out, tuple(args.packages))
    for line in problems:
        print(line, file=sys.stderr)
    print(f'{args.out / "index.html"}: {len(problems)} warning(s)')
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
