"""A ladder study's page, its one sentence and its figures, by its data: a study whose
runs recorded what they explored (``evals.csv`` with ``coverage``, ``run.coverage``) is a
study of exploring (:mod:`jaxnav.report.exploring`), one with greedy evaluations while
training (``evals.csv``, ``eval_points``) a study of learning
(:mod:`jaxnav.report.learning`), one of a single strategy and several agents a study of
options (:mod:`jaxnav.report.options`), any other a ladder (:mod:`jaxnav.report.ladder`)."""

from __future__ import annotations

from pathlib import Path

from jaxnav.report import exploring, ladder, learning, options


def of_learning(folder: Path) -> bool:
    return (Path(folder) / ladder.LEARNING_FILES[0]).is_file()


def of_exploring(folder: Path) -> bool:
    path = Path(folder) / ladder.LEARNING_FILES[0]
    return path.is_file() and "coverage" in path.read_text().split("\n", 1)[0].split(",")


def of_options(folder: Path) -> bool:
    return not of_exploring(folder) and options.of_options(ladder.Data(folder))


def figure_names(folder: Path) -> tuple[str, ...]:
    """The figures of a study's page, ``PREFIX-NAME`` beside it."""
    if of_options(folder):
        return options.FIGURES
    if of_exploring(folder):
        return exploring.FIGURES
    return learning.FIGURES if of_learning(folder) else ladder.FIGURES


def page(folder: Path, prefix: str) -> str:
    if of_options(folder):
        return options.options_markdown(folder, prefix)
    if of_exploring(folder):
        return exploring.exploring_markdown(folder, prefix)
    if of_learning(folder):
        return learning.learning_markdown(folder, prefix)
    return ladder.ladder_markdown(folder, prefix)


def sentence(folder: Path) -> str:
    if of_options(folder):
        return options.summary_sentence(ladder.Data(folder))
    if of_exploring(folder):
        return exploring.summary_sentence(ladder.Data(folder))
    data = ladder.Data(folder)
    return (learning if data.evals is not None else ladder).summary_sentence(data)


def figures(folder: Path, out: Path, prefix: str) -> list[Path]:
    if of_options(folder):
        return options.figures(folder, out, prefix)
    if of_exploring(folder):
        return exploring.figures(exploring.Exploring(ladder.Data(folder)), out, prefix)
    if of_learning(folder):
        return learning.figures(learning.Learning(ladder.Data(folder)), out, prefix)
    return ladder.ladder_figures(folder, out, prefix)
