"""Every kind of study file run one way: ``jaxnav study FILE [key=value ...] --out DIR``.

A kind (:data:`jaxnav.experiments.studyfile.KINDS`) is a module with ``load_study(path,
overrides)`` (the file read and checked whole, before any training), ``run_study(study,
out, resume_ok, quiet, command)`` (its cells trained and tested through
:mod:`jaxnav.experiments.runner`, resumable, its data into ``DIR/data/``) and
``publish(study, out, page)`` (the page from the data, the data beside it).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import Any, NamedTuple

from jaxnav.experiments import campaign, driving, ladder, studyfile


def kinds() -> dict[str, ModuleType]:
    return {"ladder": ladder, "driving": driving, "sim2sim": campaign}


class StudyFile(NamedTuple):
    kind: ModuleType  # the module that runs it
    study: Any  # what its load_study read


def is_study(path: str) -> bool:
    """Whether a YAML file is a study file (of any kind) rather than a config."""
    return studyfile.kind_of(path) is not None


def load(path: str, overrides: Sequence[str] = ()) -> StudyFile:
    """A study file of any kind, read and checked whole, with ``key=value`` overrides."""
    kind = kinds()[studyfile.kind_of(path)]
    return StudyFile(kind, kind.load_study(path, overrides))


def run(
    study: StudyFile, out: Path, page: Path, resume_ok: bool, quiet: bool, command: str
) -> list[Path]:
    """Train and test every cell of the study into ``out`` (finished ones reused), then
    write its page and data: the paths written, the page first and the data last."""
    study.kind.run_study(study.study, out, resume_ok, quiet, command)
    return study.kind.publish(study.study, out, page)
