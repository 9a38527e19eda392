"""The compiled-kernel cache follows every engine source file, not only the defining one."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numba
import pytest

from reference import jit


def test_digest_changes_with_any_engine_file(tmp_path):
    copy = tmp_path / "reference"
    shutil.copytree(jit.ENGINE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    assert jit.source_digest(copy) == jit.source_digest()
    # an edit of a callee (time functions inlined into the step kernel) must give another cache
    callee = copy / "interactions.py"
    callee.write_text(callee.read_text() + "\n# edited\n")
    assert jit.source_digest(copy) != jit.source_digest()


@pytest.mark.skipif(bool(os.environ.get("NUMBA_CACHE_DIR")), reason="the user chose the cache folder")
def test_cache_folder_is_named_after_the_digest():
    assert Path(numba.config.CACHE_DIR).name == jit.source_digest()
