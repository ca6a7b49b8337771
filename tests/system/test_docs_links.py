"""The documents hold together: every relative link in README.md and docs/ reaches a file of the
repository (and, for a Markdown page, a heading of it), and no file cites a design file or a path
that lies outside the repository."""

import re
import subprocess
import unicodedata
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
DOCUMENTS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")
# Spelled in two pieces so that this file does not cite them itself.
FORBIDDEN = ("DESIGN" + ".md", "../" + "shared", "/work" + "/")


def slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces to hyphens."""
    text = unicodedata.normalize("NFC", heading.strip().lower())
    text = re.sub(r"[`*_]", "", text)
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)  # no headings in code
    return {slug(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.+?)\s*#*$", text, re.M)}


def links(page: Path) -> list[str]:
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
    text = re.sub(r"`[^`\n]*`", "", text)  # inline code is not a link
    return [a or b for a, b in LINK.findall(text)]


def test_the_documents_exist_and_the_readme_is_short():
    assert (REPO / "docs" / "index.md").is_file() and len(DOCUMENTS) > 5
    assert len((REPO / "README.md").read_bytes()) <= 12 * 1024


def test_slug_follows_github():
    assert (
        slug("Other models: Spencer's MR-damper model, the classic Bouc-Wen, your own")
        == "other-models-spencers-mr-damper-model-the-classic-bouc-wen-your-own"
    )
    assert slug("Signals: recorded or estimated") == "signals-recorded-or-estimated"
    assert slug("The `bwbench` command") == "the-bwbench-command"


@pytest.mark.parametrize("page", DOCUMENTS, ids=lambda p: str(p.relative_to(REPO)))
def test_every_relative_link_resolves(page):
    broken = []
    for target in links(page):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # https:, mailto: ...: not a file of the repository
            continue
        path_part, _, anchor = target.partition("#")
        resolved = (page.parent / path_part).resolve() if path_part else page
        if not resolved.exists() or REPO not in (resolved, *resolved.parents):
            broken.append(f"{target}: no such file in the repository")
        elif anchor and resolved.suffix == ".md" and anchor not in anchors(resolved):
            broken.append(f"{target}: no heading #{anchor} in {resolved.relative_to(REPO)}")
    assert not broken, f"{page.relative_to(REPO)}: " + "; ".join(broken)


def test_a_broken_link_is_found(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("# Here\n[ok](#here) [bad](#there) `[not](a-link.md)`\n", encoding="utf-8")
    assert links(page) == ["#here", "#there"] and anchors(page) == {"here"}


def test_no_file_cites_a_design_file_or_a_path_outside_the_repository():
    tracked = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True, check=True).stdout
    offenders = []
    for name in filter(None, tracked.decode().split("\0")):
        path = REPO / name
        if name.startswith("reports/") or not path.is_file() or path == Path(__file__).resolve():
            continue  # reports/ are generated: they record where a study read its data
        try:
            text = path.read_text(encoding="utf-8")
        except (UnicodeDecodeError, OSError):
            continue  # binary files (figures, databases)
        for number, line in enumerate(text.splitlines(), 1):
            offenders += [f"{name}:{number}: {word}" for word in FORBIDDEN if word in line]
    assert not offenders, "\n".join(offenders)
