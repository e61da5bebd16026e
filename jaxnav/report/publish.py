"""Every part of the docs written from committed data, and the one function that writes
them (``jaxnav publish``).

A published part is either a whole page or a block between ``<!-- NAME: begin -->``
and ``<!-- NAME: end -->`` markers in one or more pages; its text is a pure function of
the data under ``docs/`` (no JAX, no training). :data:`PUBLISHED` lists them all;
``jaxnav publish`` rewrites them after a study or a campaign has committed new data,
and ``tests/test_published.py`` checks each one against its data byte for byte.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from jaxnav.core.errors import JaxnavError
from jaxnav.core.rundir import atomic_write_text


@dataclass(frozen=True)
class Published:
    name: str  # the block's marker name, or the page's
    pages: tuple[str, ...]  # paths from the repository's root
    render: Callable[[Path], str]  # (root) -> the text
    block: bool = True  # between the markers; False: the whole page
    slow: bool = False  # bootstrap intervals over many cells: tens of seconds

    def markers(self) -> tuple[str, str]:
        return f"<!-- {self.name}: begin -->", f"<!-- {self.name}: end -->"


def between(text: str, name: str) -> str:
    """The text of ``name``'s block in ``text`` (a one-line JaxnavError if it has none)."""
    begin, end = f"<!-- {name}: begin -->", f"<!-- {name}: end -->"
    if begin not in text or end not in text.split(begin, 1)[1]:
        raise JaxnavError(f"publish: no {name} markers ({begin} ... {end})")
    return text.split(begin, 1)[1].split(end, 1)[0]


def with_block(text: str, name: str, block: str) -> str:
    """``text`` with ``name``'s block replaced by ``block`` (stripped, on its own lines)."""
    between(text, name)  # the markers are there
    begin, end = f"<!-- {name}: begin -->", f"<!-- {name}: end -->"
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f"{head}{begin}\n{block.strip()}\n{end}{tail}"


def published_text(item: Published, root: Path, page: str, rendered: str | None = None) -> str:
    """What ``page`` should hold for ``item`` (``rendered``: its text, if computed)."""
    text = item.render(root) if rendered is None else rendered
    if not item.block:
        return text
    return with_block((root / page).read_text(), item.name, text)


def stale(root: Path, names: tuple[str, ...] = ()) -> list[str]:
    """The pages (``page (name)``) whose published parts differ from their data."""
    out = []
    for item in select(names):
        rendered = item.render(root)
        for page in item.pages:
            if (root / page).read_text() != published_text(item, root, page, rendered):
                out.append(f"{page} ({item.name})")
    return out


def publish(root: Path, names: tuple[str, ...] = ()) -> list[str]:
    """Rewrite the published parts (all, or those named) from their data; the pages
    that changed."""
    changed = []
    for item in select(names):
        rendered = item.render(root)
        for page in item.pages:
            new = published_text(item, root, page, rendered)
            if not (root / page).is_file() or (root / page).read_text() != new:
                atomic_write_text(root / page, new)
                changed.append(page)
    return changed


def select(names: tuple[str, ...]) -> list[Published]:
    """The published parts named (every one for none); an unknown name is one line."""
    known = {p.name: p for p in PUBLISHED}
    for n in names:
        if n not in known:
            raise JaxnavError(f"publish: no published part {n!r} (known: {', '.join(known)})")
    return [known[n] for n in names] if names else list(PUBLISHED)


# ----------------------------------------------------------------------------
# The published parts
# ----------------------------------------------------------------------------

LADDER = "docs/studies/when-ebe-helps"
LADDER_40K = "docs/studies/when-ebe-helps-40k"  # the first ladder: 40,960 env steps per seed
AGENTS_STUDY = "docs/studies/agents"
HARD_EXPLORATION = "docs/studies/hard-exploration"  # EBE beside the field's exploration methods
WORLDS_STUDY = "docs/studies/worlds"
EBE_ANYWHERE = "docs/studies/ebe-anywhere"  # EBE training the generalist, held-out worlds
OBSERVATION = "docs/studies/observation-anywhere"  # the generalist's observation options
CURRICULUM = "docs/studies/curriculum-anywhere"  # level replay for the generalist


def _study_sentence(folder: str) -> Callable[[Path], str]:
    """A committed study's one-sentence summary, from its data folder."""

    def render(root: Path) -> str:
        from jaxnav.report import study_pages

        return study_pages.sentence(root / folder)

    return render


def _held_out_sentence(folder: str) -> Callable[[Path], str]:
    """A committed study's sentence on the kinds of world its policies never saw."""

    def render(root: Path) -> str:
        from jaxnav.report.heldout import held_out_sentence
        from jaxnav.report.ladder import Data

        return held_out_sentence(Data(root / folder))

    return render


def _study_page(folder: str) -> Callable[[Path], str]:
    """A committed study's page (``folder``.md), from its data folder."""

    def render(root: Path) -> str:
        from jaxnav.report import study_pages

        return study_pages.page(root / folder, Path(folder).name)

    return render


def _study_page_entry(name: str, folder: str) -> Published:
    """The published part of a committed study's whole page (``folder``.md)."""
    return Published(name, (f"{folder}.md",), _study_page(folder), block=False, slow=True)


def _driving_readme(root: Path) -> str:
    from jaxnav.report.driving_page import readme_block

    return readme_block(root / "docs" / "driving")


def _driving_page(root: Path) -> str:
    from jaxnav.report.driving_page import (
        commands_of,
        config_tests,
        configs_of,
        driving_markdown,
        machines_of,
    )

    folder = root / "docs" / "driving"
    meta = json.loads((folder / "run.json").read_text())
    configs = configs_of(folder)
    return driving_markdown(
        folder, commands_of(meta, configs), machines_of(meta, configs), config_tests(meta, configs)
    )


def _agents_sac(root: Path) -> str:
    from jaxnav.report.agents_sac import block

    return block(root / "docs" / "driving")


def _baselines_page(root: Path) -> str:
    from jaxnav.report.baselines_page import baselines_markdown

    folder = root / "docs" / "baselines"
    meta = json.loads((folder / "notes.json").read_text())
    text = (folder / "baselines.csv").read_text()
    return baselines_markdown(text, meta["command"], meta["machine"], meta["notes"])


def _barn_page(root: Path) -> str:
    from jaxnav.report.barn_page import barn_markdown

    return barn_markdown(root)


def _barn_burger(root: Path) -> str:
    from jaxnav.report.barn_page import burger_rows, burger_sentence

    return burger_sentence(burger_rows(root))


def _barn_readme(root: Path) -> str:
    from jaxnav.report.barn_page import readme_line

    return readme_line(root)


def _campaign_page(stem: str) -> Callable[[Path], str]:
    """A sim-to-sim campaign's page (``stem``.md) from ``stem``.csv and ``stem``.json."""

    def render(root: Path) -> str:
        from jaxnav.report.sim2sim_tables import campaign_markdown

        made = json.loads((root / f"{stem}.json").read_text())
        return campaign_markdown((root / f"{stem}.csv").read_text(), made)

    return render


SIM2SIM_DRIVE = "docs/sim2sim_drive"  # CONFIG.csv: jaxnav sim2sim of a driving-study run
SIM2SIM_DRIVE_RUNS = (("drive_obstacles", "PQN"), ("drive_sac_obstacles", "SAC"))


def _sim2sim_drive(root: Path) -> str:
    """The gap tables of the policies that drive (PQN's and SAC's on square4_obstacles),
    each from its committed CSV, their headings moved two levels down."""
    from jaxnav.report.sim2sim_tables import gap_markdown

    parts = []
    for config, agent in SIM2SIM_DRIVE_RUNS:
        path = root / SIM2SIM_DRIVE / f"{config}.csv"
        md = gap_markdown(path.read_text(), f"{agent}: `{config}`, jaxnav and MuJoCo")
        parts.append("\n".join("##" + ln if ln.startswith("#") else ln for ln in md.splitlines()))
    return "\n\n".join(parts)


REALISM = "docs/sim2sim_realism"
WHEEL_LIMIT = "docs/sim2sim_wheel_limit"

PUBLISHED: tuple[Published, ...] = (
    Published(
        "when-ebe-helps", ("README.md", "docs/studies.md"), _study_sentence(LADDER), slow=True
    ),
    _study_page_entry("when-ebe-helps-page", LADDER),
    _study_page_entry("when-ebe-helps-40k-page", LADDER_40K),
    Published("hard-exploration", ("README.md",), _study_sentence(HARD_EXPLORATION), slow=True),
    _study_page_entry("hard-exploration-page", HARD_EXPLORATION),
    Published(
        "ebe-anywhere",
        ("README.md", "docs/studies.md"),
        _held_out_sentence(EBE_ANYWHERE),
        slow=True,
    ),
    _study_page_entry("ebe-anywhere-page", EBE_ANYWHERE),
    Published(
        "observation-anywhere",
        ("docs/studies.md", "jaxnav/policies/drive_anywhere.md"),
        _study_sentence(OBSERVATION),
        slow=True,
    ),
    _study_page_entry("observation-anywhere-page", OBSERVATION),
    Published(
        "curriculum-anywhere",
        ("docs/studies.md", "jaxnav/policies/drive_anywhere.md"),
        _study_sentence(CURRICULUM),
        slow=True,
    ),
    _study_page_entry("curriculum-anywhere-page", CURRICULUM),
    Published("agents-study", ("docs/agents.md",), _study_sentence(AGENTS_STUDY), slow=True),
    _study_page_entry("agents-study-page", AGENTS_STUDY),
    Published("driving", ("README.md",), _driving_readme, slow=True),
    Published("driving-page", ("docs/driving.md",), _driving_page, block=False, slow=True),
    Published("agents-sac", ("docs/agents.md",), _agents_sac, slow=True),
    Published("baselines-page", ("docs/baselines.md",), _baselines_page, block=False, slow=True),
    Published("worlds-study", ("docs/worlds.md",), _study_sentence(WORLDS_STUDY), slow=True),
    _study_page_entry("worlds-study-page", WORLDS_STUDY),
    Published("sim2sim-drive", ("docs/sim2sim.md",), _sim2sim_drive, slow=True),
    Published("barn", ("README.md",), _barn_readme),
    Published("barn-page", ("docs/barn.md",), _barn_page, block=False),
    Published("barn-burger", ("jaxnav/policies/drive_anywhere.md",), _barn_burger),
    Published(
        "sim2sim-realism-page",
        (f"{REALISM}.md",),
        _campaign_page(REALISM),
        block=False,
        slow=True,
    ),
    Published(
        "sim2sim-wheel-limit-page",
        (f"{WHEEL_LIMIT}.md",),
        _campaign_page(WHEEL_LIMIT),
        block=False,
        slow=True,
    ),
)


__all__ = [
    "PUBLISHED",
    "Published",
    "between",
    "publish",
    "select",
    "stale",
    "with_block",
]
