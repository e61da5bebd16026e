"""The ablation's tables: computed from per-seed scores that reproduce the claims."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np
import pytest

from jaxnav.commands import ablation as ablation_command
from jaxnav.experiments import ablation
from jaxnav.report import stats
from jaxnav.report.paper import PAPER_TABLES

ROOT = Path(__file__).resolve().parent.parent
REPORT = ROOT / "docs" / "report"


@pytest.fixture(scope="module")
def report_rows():
    if not (REPORT / "claims.md").is_file():
        pytest.skip("no committed report")
    return ablation.score_rows("jaxnav", REPORT)


@pytest.mark.slow
def test_scores_round_trip_through_csv_and_give_the_claims_verdicts(report_rows):
    # docs/report/claims.md is the claims code's own output on the same runs
    # (tests/test_report.py); the ablation must judge every claim the same way.
    rows = list(csv.DictReader(io.StringIO(ablation.rows_to_csv(report_rows))))
    md = ablation.ablation_markdown(rows)
    claims = [
        [c.strip() for c in line.strip("|").split("|")]
        for line in (REPORT / "claims.md").read_text().splitlines()
        if line.startswith("| Fig") or line.startswith("| Table")
    ]
    assert len(claims) == 20
    for source, statement, mode, p, verdict, _ in claims:
        line = f"| {source}: {statement} | {mode} | {p} {verdict[0].upper()} |"
        assert line in md, line


def test_magnitude_is_the_mean_over_seeds_and_table_mazes(report_rows):
    scores = ablation._scores(report_rows)
    rows = ablation.magnitude_rows(scores, ["jaxnav"])
    (row,) = [r for r in rows if r[1:4] == ("paper_no_obstacles", "greedy", "ebe")]
    table = PAPER_TABLES["square4"][1]
    assert row[5] == pytest.approx(np.mean([table[m][1]["ebe"][0] for m in table]))
    # Independently: each seed's mean greedy test return per maze, from results.csv.
    by_seed: dict[int, list[float]] = {}
    text = (REPORT / "paper_no_obstacles" / "eval" / "results.csv").read_text()
    for r in csv.DictReader(io.StringIO(text)):
        if r["mode"] == "greedy" and r["strategy"] == "ebe":
            by_seed.setdefault(int(r["seed"]), []).append(float(r["return"]))
    want = np.mean([np.mean(v) for v in by_seed.values()])
    assert row[4].value == pytest.approx(want, rel=1e-9)
    assert row[6] == pytest.approx(want / row[5])
    assert row[4].low < want < row[4].high


def test_quick_tables_say_so_and_list_only_the_variants_run():
    rows = []
    rng = np.random.default_rng(0)
    for variant in ("jaxnav", "late_actions"):
        for claim in ablation._table_claims("paper_obstacles"):
            for strategy in ("ebe", "epsilon_greedy"):
                for seed in range(3):
                    rows.append(
                        {
                            "variant": variant,
                            "source": claim.source,
                            "statement": claim.statement,
                            "mode": "greedy",
                            "strategy": strategy,
                            "seed": str(seed),
                            "task": "0",
                            "score": str(rng.normal(500, 100)),
                        }
                    )
    md = ablation.ablation_markdown(rows, quick=True)
    assert "not conclusive" in md
    assert "| late_actions |" in md and "| gazebo_beams |" not in md
    iv = stats.mean_ci(np.zeros((3, 1)))
    assert not math.isnan(iv.value)


def test_unknown_variant_is_one_line(capsys):
    assert ablation_command.main(["--variants", "jaxnav,nope", "--out", "/tmp/x"]) == 2
    err = capsys.readouterr().err.strip()
    assert "unknown variant 'nope'" in err and "\n" not in err


@pytest.mark.slow
def test_the_committed_ablation_is_computed_from_its_scores():
    doc = ROOT / "docs" / "ablation"
    if not (doc / "ablation.md").is_file():
        pytest.skip("no committed ablation")
    rows = list(csv.DictReader((doc / "ablation.csv").open()))
    tables = ablation.ablation_markdown(rows)
    committed = (doc / "ablation.md").read_text()
    assert committed.startswith(tables)
    page = (ROOT / "docs" / "reproducing.md").read_text()
    quoted = [line for line in page.splitlines() if line.startswith("| jaxnav |")]
    assert quoted, "docs/reproducing.md quotes the ablation's reference rows"
    for line in page.splitlines():
        if line.startswith("| ") and any(line.startswith(f"| {v} |") for v in ablation.VARIANTS):
            assert line in tables, line


@pytest.mark.slow
def test_the_robotis_goals_confirmation_is_computed_from_its_results():
    import gzip

    from jaxnav.report.tables import tables_markdown

    d = Path(__file__).resolve().parent.parent / "docs" / "ablation" / "robotis_goals-confirm"
    text = gzip.decompress((d / "results.csv.gz").read_bytes()).decode()
    tables = tables_markdown(text, "square4", 100, title="Test results of confirm_goals")
    assert tables == (d / "tables.md").read_text()
    assert "| all mazes | 0.57 [0.46, 0.67] |" in tables  # quoted in its README


@pytest.mark.slow  # the ablation's tables twice: about a minute
def test_ablations_run_apart_merge_into_one_with_their_tables_recomputed(tmp_path, capsys):
    doc = ROOT / "docs" / "ablation"
    rows = list(csv.DictReader((doc / "ablation.csv").open()))
    variants = sorted({r["variant"] for r in rows})
    assert len(variants) >= 2
    parts = []
    for i, chosen in enumerate((variants[:1], variants[1:])):
        part = tmp_path / f"part{i}"
        part.mkdir()
        mine = [r for r in rows if r["variant"] in chosen]
        (part / "ablation.csv").write_text(ablation.rows_to_csv(mine))
        (part / "ablation.md").write_text(f"# Part {i}\n\n## Wall-clock\n\nrun {i} took 1 s\n")
        parts.append(str(part))
    out = tmp_path / "merged"
    assert ablation_command.main(["--merge", *parts, "--out", str(out)]) == 0
    merged = list(csv.DictReader((out / "ablation.csv").open()))
    key = sorted(tuple(r.values()) for r in rows)
    assert sorted(tuple(r.values()) for r in merged) == key
    text = (out / "ablation.md").read_text()
    assert text.startswith(ablation.ablation_markdown(merged))
    assert "### Wall-clock\n\nrun 0 took 1 s" in text and "run 1 took 1 s" in text
    capsys.readouterr()
    # a variant in two parts, a part without its files: one line, exit 2
    assert ablation_command.main(["--merge", parts[0], parts[0], "--out", str(out)]) == 2
    assert f"is in both {parts[0]} and {parts[0]}" in capsys.readouterr().err
    assert ablation_command.main(["--merge", str(tmp_path), "--out", str(out)]) == 2
    assert "has no ablation.csv" in capsys.readouterr().err
    assert ablation_command.main(["--merge", parts[0]]) == 2
    assert "--merge needs --out" in capsys.readouterr().err
