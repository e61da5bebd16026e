"""What ships with jaxnav besides code, found by name: the configs and maze files
(package data under ``jaxnav/configs/``, so they work from an installed wheel), a
built-in config's or study's name resolved to its file, their listings with a line
each (``jaxnav list``), and did-you-mean for a mistyped name. No JAX.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import yaml

# The shipped configs and maze files: package data, so they work from an installed wheel.
CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"
STUDY_DIR = CONFIG_DIR / "studies"  # the study files: jaxnav study when_ebe_helps


def shipped_path(path: str) -> str:
    """``path`` if it exists, else the shipped file it names: ``configs/smoke.yaml`` or
    ``configs/mazes/corridor.yaml`` resolve to the package's copy from any folder."""
    if os.path.exists(path):
        return path
    rel = Path(path)
    if rel.parts[:1] == ("configs",):
        cand = CONFIG_DIR.joinpath(*rel.parts[1:])
        if cand.is_file():
            return str(cand)
    return path


def resolve_config_path(name: str) -> str:
    """A config path, a built-in config's name (``smoke``: ``configs/smoke.yaml``), a
    shipped study's (``when_ebe_helps``: ``configs/studies/when_ebe_helps.yaml``), or a
    path under ``configs/`` from any folder; a missing one is returned unchanged."""
    if os.path.isfile(name):
        return name
    for cand in (CONFIG_DIR / name, CONFIG_DIR / f"{name}.yaml", STUDY_DIR / f"{name}.yaml"):
        if cand.is_file() and "/" not in name:
            return str(cand)  # a folder of that name here does not hide the shipped file
    return shipped_path(name)


# A full stop after one of these ends no sentence ("Sec. 6.1", "et al. 2024").
_ABBREVIATIONS = ("Sec", "al", "e.g", "i.e", "cf", "Fig", "Eq", "vs", "approx")
_SENTENCE_END = re.compile("".join(rf"(?<!\b{re.escape(a)})" for a in _ABBREVIATIONS) + r"\.\s+")


def builtin_configs() -> dict[str, str]:
    """Each shipped config's name and the first sentence of its opening comment (the
    comment's lines up to an indented example command or the first full stop that
    ends a sentence, whatever follows it: "budget. 8 seeds", "cores. docs/...")."""
    out = {}
    for path in sorted(CONFIG_DIR.glob("*.yaml")):
        words = []
        for line in path.read_text().splitlines():
            if not line.startswith("#") or line.startswith("#  "):
                break
            words.append(line.lstrip("# ").strip())
        text = " ".join(w for w in words if w)
        out[path.stem] = _SENTENCE_END.split(text)[0].rstrip(" ,.:;")
    return out


def shipped_studies(key: str = "title") -> dict[str, str]:
    """Each shipped study file's name and its ``key`` (``configs/studies/NAME.yaml``):
    its title, or ``cost``, what a whole run of it took (empty where it says none)."""
    out = {}
    for path in sorted(STUDY_DIR.glob("*.yaml")):
        try:
            doc = yaml.safe_load(path.read_text())
        except yaml.YAMLError:
            doc = None
        if isinstance(doc, dict):
            out[path.stem] = str(doc.get(key, "")).strip()
    return out


def studies_text() -> str:
    """The shipped studies, a line each with what a whole run of it took."""
    titles, costs = shipped_studies(), shipped_studies("cost")
    if not titles:
        return ""
    width = max(map(len, titles))
    pad = " " * (width + 4)
    lines = []
    for name, title in titles.items():
        lines.append(f"  {name:<{width}}  {title}")
        if costs[name]:
            lines.append(f"{pad}cost: {costs[name]}")
    return "\n".join(lines)


def did_you_mean_config(name: str) -> str:
    """`` (did you mean 'smoke'?)`` for a mistyped shipped config's or study's name, or
    nothing: the nearest of them to ``name``, if near enough."""
    from difflib import get_close_matches

    names = [*builtin_configs(), *shipped_studies()]
    near = get_close_matches(Path(name).stem, names, n=1, cutoff=0.75)
    return f" (did you mean {near[0]!r}? jaxnav list shows them)" if near else ""


__all__ = [
    "CONFIG_DIR",
    "STUDY_DIR",
    "builtin_configs",
    "did_you_mean_config",
    "resolve_config_path",
    "shipped_path",
    "shipped_studies",
    "studies_text",
]
