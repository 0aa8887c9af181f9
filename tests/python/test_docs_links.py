"""Every relative markdown link in the user documents resolves: the file exists and, for
a #anchor into a markdown file, a heading of that file has that GitHub anchor."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DOCUMENTS = [*sorted((REPO / "docs").glob("*.md")), REPO / "README.md",
             REPO / "configs" / "README.md", REPO / "tools" / "python" / "README.md"]
FENCE = re.compile(r"^```.*?^```", re.S | re.M)
LINK = re.compile(r"\]\(([^)\s]+)\)")


def anchors(markdown: Path) -> set[str]:
    """GitHub's heading anchors: lower case, punctuation dropped, spaces to '-', -N for repeats."""
    found: set[str] = set()
    seen: dict[str, int] = {}
    for line in FENCE.sub("", markdown.read_text()).splitlines():
        heading = re.match(r"^#{1,6} +(.*?) *#*$", line)
        if not heading:
            continue
        slug = re.sub(r"[^\w\- ]", "", heading.group(1).strip().lower()).replace(" ", "-")
        count = seen.get(slug, 0)
        seen[slug] = count + 1
        found.add(slug if count == 0 else f"{slug}-{count}")
    return found


def broken_links(markdown: Path) -> list[str]:
    """The relative links of one document that name a missing file or heading."""
    broken = []
    for target in LINK.findall(FENCE.sub("", markdown.read_text())):
        if re.match(r"^[a-z]+:", target):  # http:, https:, mailto:
            continue
        file, _, anchor = target.partition("#")
        destination = (markdown.parent / file) if file else markdown
        if not destination.exists():
            broken.append(f"{target}: no such file")
        elif anchor and destination.suffix == ".md" and anchor not in anchors(destination):
            broken.append(f"{target}: no such heading")
    return broken


def test_every_relative_link_of_the_documents_resolves():
    problems = {str(doc.relative_to(REPO)): broken_links(doc) for doc in DOCUMENTS if doc.exists()}
    assert {doc: links for doc, links in problems.items() if links} == {}


def test_a_missing_file_or_heading_is_reported(tmp_path):
    (tmp_path / "other.md").write_text("# Other, part 2\n## Repeat\n## Repeat\n")
    doc = tmp_path / "doc.md"
    doc.write_text("# Top\n[a](other.md#other-part-2) [b](other.md#repeat-1) [c](#top)\n"
                   "[d](missing.md) [e](other.md#nowhere) [f](https://example.org/x)\n"
                   "```\n[g](ignored-in-code.md)\n```\n")
    assert broken_links(doc) == ["missing.md: no such file", "other.md#nowhere: no such heading"]
