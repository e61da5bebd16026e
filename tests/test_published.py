"""The committed pages built from committed data say what their data say: rebuilding
their generated parts from docs/ gives the same text."""

from __future__ import annotations

import importlib.util
from pathlib import Path

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
