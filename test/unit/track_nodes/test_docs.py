"""The docs are self-contained: the design, the papers and the measured results are in the repository.

No tracked file points at the sibling folders a user's clone does not have (the papers' texts,
the design notes, the ROS notes); every DESIGN.md/PAPERS.md reference resolves in ``docs/``; the
papers are cited by title and authors, and every module PAPERS.md names exists. Every relative
link of a tracked Markdown file resolves (file and heading); the README is a user's page (at most
150 lines, no issue numbers) and the results index links every page of ``docs/results/``.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
OUTSIDE = ('../shared/papers', 'shared/DESIGN', 'ROS_NOTES', '../shared/README')
TITLES = ('Blending Sensor Scheduling Strategy with Particle Filter to Track a Smart Target',
          'Recognized Maritime Picture: Geofeasibility Scores',
          'Particle Filter Object Tracking by a Handheld UHF RFID Reader',
          'Collaborative In-Network Processing for Target Tracking',
          'Hybrid Architecture for Simultaneous Localization and Map Building in Large Outdoor Areas')


def _tracked_text() -> dict[str, str]:
    names = subprocess.run(['git', 'ls-files'], cwd=REPO, capture_output=True, text=True, check=True).stdout.split()
    out = {}
    for name in names:
        path = REPO / name
        if path.suffix in {'.py', '.md', '.yaml', '.txt', '.cfg', '.toml', '.xml', ''} and path.is_file():
            try:
                out[name] = path.read_text(encoding='utf-8')
            except UnicodeDecodeError:
                continue
    return out


def test_nothing_points_outside_the_repository():
    bad = [f'{name}: {needle}' for name, text in _tracked_text().items() if name != 'test/unit/track_nodes/test_docs.py'
           for needle in OUTSIDE if needle in text]
    assert bad == []


def test_design_references_resolve_in_docs():
    for name, text in _tracked_text().items():
        for ref in re.findall(r'\b(?:docs/)?(DESIGN|PAPERS)\.md', text):
            assert (REPO / 'docs' / f'{ref}.md').is_file(), (name, ref)
    readme = (REPO / 'README.md').read_text()
    assert 'docs/PAPERS.md' in readme and 'docs/DESIGN.md' in readme


def test_papers_are_cited_by_title_and_their_modules_exist():
    papers = (REPO / 'docs/PAPERS.md').read_text()
    assert all(title in papers for title in TITLES)
    core = REPO / 'src/track_core/track_core'
    for module in re.findall(r'`([a-z_]+/[a-z_]+\.py)`', papers):
        assert (core / module).is_file(), module


LINK = re.compile(r'\[[^\]]*\]\(([^)\s]+)\)')


def _anchors(markdown: str) -> set[str]:
    """GitHub's heading ids: lower case, punctuation dropped but '-' and '_', spaces to '-'."""
    out = set()
    for line in markdown.splitlines():
        if line.startswith('#'):
            title = line.lstrip('#').strip().lower()
            out.add(re.sub(r'[^\w\- ]', '', title).replace(' ', '-'))
    return out


def test_relative_links_resolve():
    texts = _tracked_text()
    bad = []
    for name, text in texts.items():
        if not name.endswith('.md'):
            continue
        for target in LINK.findall(text):
            if re.match(r'[a-z]+:', target):
                continue  # http(s), mailto: not checked here
            path, _, anchor = target.partition('#')
            resolved = (REPO / name).parent / path if path else REPO / name
            if not resolved.exists():
                bad.append(f'{name}: {target}')
            elif anchor and resolved.suffix == '.md' and anchor not in _anchors(resolved.read_text(encoding='utf-8')):
                bad.append(f'{name}: {target} (no such heading)')
    assert bad == []


def test_readme_is_a_users_page():
    readme = (REPO / 'README.md').read_text(encoding='utf-8')
    assert len(readme.splitlines()) <= 150
    assert re.findall(r'\bissues? \d+', readme, flags=re.IGNORECASE) == []
    assert 'docs/results/README.md' in readme and 'CHANGELOG.md' in readme


def test_results_index_links_every_page():
    results = REPO / 'docs/results'
    index = (results / 'README.md').read_text(encoding='utf-8')
    pages = sorted(p.name for p in results.glob('*.md') if p.name != 'README.md')
    assert pages and [p for p in pages if f']({p})' not in index] == []
