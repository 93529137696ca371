"""The quick validation report, made once for the validation tests and the validation example
(the environment is set in the root conftest.py)."""

import pytest


@pytest.fixture(scope="session")
def report(tmp_path_factory):
    """``demes validate --quick`` on the paper scene: (folder, files)."""
    import scenes
    from validation.validate import validate

    out = tmp_path_factory.mktemp("report")
    files = validate(scenes.load("demes_paper"), out, quick=True, workers=2, progress=False)
    return out, files
