"""The compiled-kernel cache follows every engine source file, not only the defining one; named tuples
cross into kernels as plain tuples and are named again inside."""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np
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


class _Pair(NamedTuple):
    a: np.ndarray
    b: np.ndarray


class _Other(NamedTuple):  # the same plain type as _Pair: the class tells them apart
    first: np.ndarray
    second: np.ndarray


class _Nested(NamedTuple):
    pair: _Pair
    scale: float


@numba.njit
def _through_boundary(nested, other, n):
    nested = jit.named(nested, _Nested)
    other = jit.named(other, _Other)
    for i in range(n):
        nested.pair.b[i] = nested.scale * nested.pair.a[i] + other.second[i]
    return nested.pair.b.sum()


def test_boundary_copies_are_plain_and_named_again_inside_a_kernel():
    """What a kernel writes through the named view reaches the caller's arrays; a named tuple passed
    as it is works too (the identity), and the plain copy is made once per object."""
    pair = _Pair(np.arange(4.0), np.zeros(4))
    other = _Other(np.zeros(4), np.full(4, 0.5))
    nested = _Nested(pair, 2.0)
    plain = jit.boundary(nested)
    if not numba.config.DISABLE_JIT:  # plain Python passes the named tuples themselves
        assert type(plain) is tuple and type(plain[0]) is tuple and plain[0][0] is pair.a
    assert _through_boundary(plain, jit.boundary(other), 4) == pytest.approx(2 * 6.0 + 2.0)
    assert pair.b.tolist() == [0.5, 2.5, 4.5, 6.5]
    pair.b[:] = 0.0
    assert _through_boundary(nested, other, 4) == pytest.approx(14.0)  # named tuples as they are
    assert pair.b.tolist() == [0.5, 2.5, 4.5, 6.5]


class _FamilyA(NamedTuple):
    conn: np.ndarray
    L0: np.ndarray


class _FamilyB(NamedTuple):  # the same field types as _FamilyA
    conn: np.ndarray
    L0: np.ndarray


class _Holder(NamedTuple):
    elements: tuple


_FamilyA._plain_tag, _FamilyB._plain_tag = "test_family_a", "test_family_b"


@numba.njit
def _family_length(holder):
    holder = jit.named(holder, _Holder)
    return holder.elements[0].L0.sum()


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="plain copies are made for compiled kernels only")
def test_two_classes_of_the_same_field_types_stay_apart_in_their_plain_copies():
    """Before: beam2_se3's and beam3's data (seven arrays of the same dimensions) had one plain type, so a
    kernel compiled for a beam3 model (in the process or in the on-disk cache) ran beam3's kernels on
    beam2_se3's arrays: out of bounds (caught with NUMBA_BOUNDSCHECK=1), a corrupted heap without it.
    A tagged class (the element families' data) carries its tag into the plain type."""
    a = _Holder((_FamilyA(np.zeros((2, 2), dtype=np.int64), np.ones(2)),))
    b = _Holder((_FamilyB(np.zeros((2, 2), dtype=np.int64), np.full(2, 3.0)),))
    plain_a, plain_b = jit.boundary(a), jit.boundary(b)
    assert numba.typeof(plain_a) != numba.typeof(plain_b)
    assert _family_length(plain_a) == 2.0 and _family_length(plain_b) == 6.0  # the tag skipped in the view
    assert len(_family_length.signatures) == 2
    from reference.elements.families import ELEMENT_FAMILIES, family_of

    tags = {getattr(cls.Data, jit.TAG, None) for name, cls in ELEMENT_FAMILIES.items() if name != "beam2"}
    assert None not in tags and len(tags) == len(ELEMENT_FAMILIES) - 1 and family_of


def test_a_run_makes_the_plain_copy_of_its_record_once():
    """The generalized-α steps take the output record at every output: the Newton system keeps its plain
    copy (a dictionary of copies in reference.jit kept up to 64 models and their arrays alive)."""
    from reference.algorithms.implicit import NewtonSystem
    from reference.domain import Domain
    from reference.state import Record

    d = Domain.from_deck(Path(__file__).resolve().parent.parent / "models" / "three_bar.toml")
    model = d.initialization()
    system = NewtonSystem(model)
    rec, other = Record.empty(len(d.nodes), model.n_constraints), Record.empty(len(d.nodes), model.n_constraints)
    first = system.record_arg(rec)
    assert system.record_arg(rec) is first  # the same record: the same copy, no new one
    assert system.record_arg(other) is not first and system.record_arg(other)[0] is other.x  # x first


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="nothing compiles with NUMBA_DISABLE_JIT=1")
def test_compile_timer_counts_compilation_once_and_announces_it_once():
    """`flexmbs run` says when it compiles and leaves the compilation out of the solve time: the timer
    counts a kernel that compiles (and the kernel it calls inside it, once), and nothing for a kernel
    already compiled."""
    announced = []

    def inner(x):
        return x * 2.0 + 1.0

    inner = numba.njit(inner)

    @numba.njit
    def outer(x):
        return inner(x) - 1.0

    with jit.CompileTimer(lambda: announced.append(1)) as timer:
        assert outer(1.5) == 3.0
        assert outer(2.5) == 5.0  # compiled: no event
    assert announced == [1] and timer.kernels == 1 and timer.seconds > 0.0
    with jit.CompileTimer(lambda: announced.append(2)) as again:
        outer(3.0)
    assert announced == [1] and again.kernels == 0 and again.seconds == 0.0
