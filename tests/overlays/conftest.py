"""Overlay fixtures: a private folder for rendered costmaps."""

import pytest


@pytest.fixture(autouse=True)
def _private_var_dir(settings, tmp_path):
    settings.VAR_DIR = tmp_path
