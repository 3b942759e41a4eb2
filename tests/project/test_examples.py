"""The documentation examples run and draw their figures (quick settings).

The CI (``.ci/run``) builds the documentation after the tests, and its Sphinx build runs every
example with ``abort_on_example_error`` (a failing example fails the build, warnings are
errors): there it sets ``LIEINT_EXAMPLES_RUN_BY_DOCS=1`` and these tests skip, so each example
runs once per CI run instead of twice. Everywhere else (the README's test command) they run.
"""

import os
import runpy
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

EXAMPLES = sorted((Path(__file__).resolve().parents[2] / "docs" / "examples").glob("plot_*.py"))


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
@pytest.mark.slow
def test_example_runs(path, monkeypatch, capsys):
    if os.environ.get("LIEINT_EXAMPLES_RUN_BY_DOCS") == "1":
        pytest.skip("the CI's Sphinx build runs every example (abort_on_example_error)")
    import matplotlib.pyplot as plt

    monkeypatch.setattr(plt, "show", lambda *a, **k: None)
    runpy.run_path(str(path), run_name="__main__")
    assert plt.get_fignums(), "an example must draw a figure"
    plt.close("all")
