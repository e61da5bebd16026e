"""The committed pages built from committed data say what their data say: rebuilding
their generated parts from docs/ gives the same text (jaxnav.report.publish lists
them; ``jaxnav publish`` writes them)."""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import unquote

import pytest

from jaxnav.commands.publish import main as publish_main
from jaxnav.core.errors import JaxnavError
from jaxnav.report import publish

ROOT = Path(__file__).resolve().parents[1]


def _marked(item: publish.Published):
    return pytest.param(item, id=item.name, marks=[pytest.mark.slow] if item.slow else [])


@pytest.mark.parametrize("item", [_marked(p) for p in publish.PUBLISHED])
def test_each_published_part_is_its_data_byte_for_byte(item):
    rendered = item.render(ROOT)
    for page in item.pages:
        text = (ROOT / page).read_text()
        if item.block:
            assert publish.between(text, item.name).strip() == rendered.strip(), page
        else:
            assert text == rendered, page


@pytest.mark.slow  # the ladder page's bootstrap intervals
def test_the_ladder_pages_figures_are_beside_it():
    from jaxnav.report import study_pages

    for folder in (publish.LADDER, publish.LADDER_40K):
        page = ROOT / f"{folder}.md"
        for name in study_pages.figure_names(ROOT / folder)[:2]:
            assert (page.parent / f"{page.stem}-{name}").is_file()


@pytest.mark.slow  # 5 s on 2 cores
def test_publish_rewrites_a_stale_block_and_check_finds_it(tmp_path, capsys):
    import shutil

    shutil.copytree(ROOT / publish.AGENTS_STUDY, tmp_path / publish.AGENTS_STUDY)
    page = tmp_path / "docs" / "agents.md"
    page.write_text("# A\n\n<!-- agents-study: begin -->\nold\n<!-- agents-study: end -->\ntail\n")
    root = ["--root", str(tmp_path)]
    assert publish_main(["agents-study", "--check", *root]) == 1
    assert "docs/agents.md (agents-study)" in capsys.readouterr().out
    assert publish_main(["agents-study", *root]) == 0
    text = page.read_text()
    assert text.startswith("# A\n\n<!-- agents-study: begin -->\nOn square4 with 3 agents")
    assert text.endswith("<!-- agents-study: end -->\ntail\n")
    assert publish_main(["agents-study", "--check", *root]) == 0
    assert publish.publish(tmp_path, ("agents-study",)) == []  # nothing left to write


def test_publish_names_what_is_wrong_in_one_line(tmp_path, capsys):
    assert publish_main(["nosuch", "--root", str(ROOT)]) == 2
    assert "no published part 'nosuch'" in capsys.readouterr().err
    assert publish_main(["--root", str(tmp_path)]) == 2
    assert "has no docs/ folder" in capsys.readouterr().err
    with pytest.raises(JaxnavError, match="no agents-study markers"):
        publish.with_block("no markers here", "agents-study", "x")


_LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_IMG = re.compile(r"<img\s[^>]*src=\"([^\"]+)\"")
_REF = re.compile(r"^\s{0,3}\[[^\]]+\]:\s+<?(\S+?)>?(?:\s|$)", re.M)


def _pages() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))] + sorted(
        (ROOT / "bench").rglob("*.md")
    )


def _relative_links(page: Path) -> list[str]:
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)  # code is not a link
    text = re.sub(r"`[^`\n]*`", "", text)
    found = [m.group(1) for p in (_LINK, _IMG, _REF) for m in p.finditer(text)]
    return [t for t in found if not re.match(r"[a-zA-Z][a-zA-Z0-9+.-]*:|#", t)]


def test_every_relative_link_and_picture_of_the_pages_exists():
    """docs/worlds.md once showed three pictures that were never committed."""
    missing, seen = [], 0
    for page in _pages():
        for target in _relative_links(page):
            seen += 1
            path = unquote(target.split("#", 1)[0].split("?", 1)[0])
            if not (page.parent / path).exists():
                missing.append(f"{page.relative_to(ROOT)}: {target}")
    assert seen > 100 and not missing, missing


def test_the_link_check_finds_a_missing_picture(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("![a](there.png) [b](page.md#x) [c](https://x.org) `[d](no.png)`\n")
    assert _relative_links(page) == ["there.png", "page.md#x"]
