"""The committed reproduction report: its claims are computed from its own data.

docs/report holds what ``jaxnav reproduce --seeds 32`` wrote: each
experiment's metrics.csv and eval/results.csv, the claims table and the report.
The claims table must be exactly what the claims code computes from those files,
and the README, docs/reproducing.md and the report must quote it unchanged.
"""

from pathlib import Path

import pytest

from jaxnav.experiments.reproduce import EXPERIMENTS, experiment_files
from jaxnav.report.claims import claims_markdown, evaluate_claims

ROOT = Path(__file__).resolve().parent.parent
REPORT = ROOT / "docs" / "report"


def _table_rows(md: str) -> list[str]:
    return [line for line in md.splitlines() if line.startswith("| ") and "---" not in line]


@pytest.fixture(scope="module")
def committed_claims():
    if not (REPORT / "claims.md").is_file():
        pytest.skip("no committed report")
    return (REPORT / "claims.md").read_text()


@pytest.mark.slow
def test_the_committed_claims_are_computed_from_the_committed_runs(committed_claims):
    verdicts = evaluate_claims(experiment_files(REPORT))
    assert claims_markdown(verdicts) == committed_claims
    assert {v.claim.experiment for v in verdicts} == {name for name, _ in EXPERIMENTS}


def test_the_readme_the_docs_and_the_report_quote_the_claims_table_unchanged(committed_claims):
    rows = _table_rows(committed_claims)
    readme = (ROOT / "README.md").read_text()
    reproducing = (ROOT / "docs" / "reproducing.md").read_text()
    report = (REPORT / "report.md").read_text()
    for row in rows:
        assert row in readme, row
        assert row in reproducing, row
        assert row in report, row


def test_a_finished_reproduction_is_published_whole_and_a_partial_one_is_refused(tmp_path, capsys):
    """jaxnav reproduce --out DIR --publish PATH copies what docs/report holds: the
    committed report, taken as a finished reproduction, comes back file for file."""
    import shutil

    from jaxnav.commands import reproduce as reproduce_command

    src = ROOT / "docs" / "report"
    dst = tmp_path / "report"
    dst.mkdir()
    (dst / "stale.md").write_text("left from an older report")
    argv = ["--out", str(src), "--publish", str(dst)]
    assert reproduce_command.main(argv) == 0
    have = sorted(p.relative_to(src) for p in src.rglob("*") if p.is_file())
    got = sorted(p.relative_to(dst) for p in dst.rglob("*") if p.is_file())
    assert got == have  # the stale file is gone, nothing is missing
    assert all((dst / p).read_bytes() == (src / p).read_bytes() for p in have)
    capsys.readouterr()
    partial = tmp_path / "partial"
    shutil.copytree(src, partial)
    (partial / "claims.md").unlink()
    assert reproduce_command.main(["--out", str(partial), "--publish", str(dst)]) == 2
    assert "has no claims.md" in capsys.readouterr().err
    assert reproduce_command.main(["--out", str(tmp_path), "--publish", str(dst)]) == 2
    assert "holds no finished reproduction" in capsys.readouterr().err
    assert got == sorted(p.relative_to(dst) for p in dst.rglob("*") if p.is_file())  # kept
