"""The committed pages built from committed data say what their data say: rebuilding
their generated parts from docs/ gives the same text."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path
from urllib.parse import unquote

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _script(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _between(text: str, begin: str, end: str) -> str:
    return text.split(begin, 1)[1].split(end, 1)[0]


def test_the_worlds_page_holds_the_grid4_runs_greedy_tables():
    mod = _script("publish_worlds_run")
    page = mod.PAGE.read_text()
    assert (
        _between(page, mod.BEGIN, mod.END).strip()
        == mod.greedy_sections(mod.TABLES.read_text()).strip()
    )


def test_the_agents_page_holds_the_tables_of_its_committed_results():
    mod = _script("agents_study")
    page = mod.PAGE.read_text()
    assert _between(page, mod.BEGIN, mod.END).strip() == mod.tables().strip()


@pytest.mark.slow  # bootstrap intervals of every committed cell: tens of seconds
def test_the_ladder_study_page_is_its_data_byte_for_byte():
    from jaxnav.report import ladder

    page = ROOT / "docs" / "studies" / "when-ebe-helps.md"
    data = page.parent / page.stem
    assert page.read_text() == ladder.ladder_markdown(data, page.stem)
    for name in ladder.FIGURES[:2]:
        assert (page.parent / f"{page.stem}-{name}").is_file()


@pytest.mark.slow  # bootstrap intervals of every committed cell: tens of seconds
def test_the_readme_sums_up_the_ladder_study_in_its_generated_sentence():
    from jaxnav.report import ladder

    mod = _script("publish_ladder")
    sentence = ladder.summary_sentence(ladder.Data(mod.DATA))
    for page in mod.PAGES:
        assert _between(page.read_text(), mod.BEGIN, mod.END).strip() == sentence


@pytest.mark.slow  # bootstrap intervals of every committed cell: tens of seconds
def test_the_baselines_page_is_its_data_byte_for_byte():
    import json

    from jaxnav.report.baselines_page import baselines_markdown

    folder = ROOT / "docs" / "baselines"
    meta = json.loads((folder / "notes.json").read_text())
    text = (folder / "baselines.csv").read_text()
    page = baselines_markdown(text, meta["command"], meta["machine"], meta["notes"])
    assert (ROOT / "docs" / "baselines.md").read_text() == page


@pytest.mark.slow  # bootstrap intervals of every committed cell: tens of seconds
def test_the_driving_page_and_the_readmes_results_are_their_data():
    import json

    from jaxnav.report.driving_page import BEGIN, END, driving_markdown, readme_block

    folder = ROOT / "docs" / "driving"
    meta = json.loads((folder / "run.json").read_text())
    page = driving_markdown(folder, meta["command"], meta["machine"])
    assert (ROOT / "docs" / "driving.md").read_text() == page
    readme = (ROOT / "README.md").read_text()
    assert _between(readme, BEGIN, END).strip() == readme_block(folder).strip()


# [text](target), ![alt](target "title"), <img src="target">, and [label]: target
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
