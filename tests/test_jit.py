"""The compiled-kernel cache follows the engine source files a kernel reaches, not only the defining one; named tuples
cross into kernels as plain tuples and are named again inside."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np
import pytest

from reference import jit, kernel_cache
from reference.domain import Domain


def test_a_kernel_is_keyed_by_what_its_module_reaches_and_nothing_else():
    """The explicit step inlines the time functions of reference/interactions.py (an edit there must compile
    it again), but neither the deck reader, the Domain nor another algorithm (an edit there must not)."""
    step = kernel_cache.closure("reference.algorithms.staggered")
    assert {"reference.interactions", "reference.jit", "reference.elements.families"} <= step
    assert not step & {"reference.io.deck", "reference.domain", "reference.algorithms.static",
                       "reference.algorithms.generalized_alpha"}
    # the element families enter by the types a kernel is compiled for, not by the registry's imports
    assert not step & {"reference.elements.beam3", "reference.elements.beam2_se3"}
    assert kernel_cache.family_modules() == {"reference.elements.beam2", "reference.elements.beam2_se3",
                                             "reference.elements.beam3"}
    assert "reference.generated.beam3" in kernel_cache.closure("reference.elements.beam3")


def test_an_edit_changes_the_digests_of_the_modules_that_reach_it(tmp_path, monkeypatch):
    copy = tmp_path / "reference"
    shutil.copytree(kernel_cache.ENGINE, copy, ignore=shutil.ignore_patterns("__pycache__"))

    engine = kernel_cache.ENGINE

    def read_afresh(root):
        monkeypatch.setattr(kernel_cache, "ENGINE", root)
        for cached in (kernel_cache.modules, kernel_cache.imports, kernel_cache.family_modules,
                       kernel_cache.closure, kernel_cache.digest):
            cached.cache_clear()

    def digests():
        read_afresh(copy)
        names = ("reference.algorithms.staggered", "reference.algorithms.static", "reference.elements.beam3",
                 "reference.elements.beam2")
        out = {name: kernel_cache.digest(name) for name in names}
        read_afresh(engine)
        return out

    before = digests()
    (copy / "interactions.py").write_text((copy / "interactions.py").read_text() + "\n# edited\n")
    callee = digests()
    assert callee["reference.algorithms.staggered"] != before["reference.algorithms.staggered"]
    assert callee["reference.elements.beam3"] == before["reference.elements.beam3"]
    (copy / "elements" / "beam3.py").write_text((copy / "elements" / "beam3.py").read_text() + "\n# edited\n")
    family = digests()
    assert family["reference.elements.beam3"] != callee["reference.elements.beam3"]
    for name in ("reference.algorithms.staggered", "reference.algorithms.static", "reference.elements.beam2"):
        assert family[name] == callee[name]


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="nothing is cached with NUMBA_DISABLE_JIT=1")
def test_a_compiled_version_is_keyed_by_the_families_its_model_carries():
    """A Beam2 model's kernels do not carry beam3's data, so their key holds beam2's digest and not beam3's;
    a model with a beam3 beam has both (an edit of beam3 compiles again only the kernels of beam3 models)."""
    from reference.algorithms.staggered import advance
    from reference.elements import Section

    section = Section(EA=1e7, GA2=1e6, GA3=1e6, GJ=1e3, EI2=1e3, EI3=1e3, rhoA=1.0, rhoJ1=1e-3, rhoJ2=1e-3,
                      rhoJ3=1e-3)
    carried = []
    for element in ("beam2", "beam3"):
        d = Domain("families")
        d.add_beam("b", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 2, section, element=element)
        model = d.initialization()
        named_types, plain_types = numba.typeof(model), numba.typeof(jit.boundary(model))
        assert kernel_cache.families_in((named_types,)) == kernel_cache.families_in((plain_types,))
        carried.append(kernel_cache.families_in((plain_types,)))
    assert carried == [{"beam2"}, {"beam2", "beam3"}]
    assert isinstance(advance._cache, kernel_cache.EngineCache)
    assert kernel_cache.family_digest("beam3") == kernel_cache.digest("reference.elements.beam3")


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="nothing is cached with NUMBA_DISABLE_JIT=1")
def test_the_element_driver_is_keyed_by_the_family_it_runs():
    """The generic driver's kernels reach no family module by imports; a version compiled for one family's
    data holds that family's digest in its key (and no other family's), so an edit of beam3 compiles them
    again for beam3 only.  The engine's families are cached on disk (:func:`reference.kernel_cache.outside`
    is false for them)."""
    from reference.elements import driver
    from reference.elements.beam3 import Beam3Data

    beam3 = numba.typeof(jit.boundary(Beam3Data(*[np.zeros((1, 1))] * len(Beam3Data._fields))))
    assert "reference.elements.beam3" not in kernel_cache.closure("reference.elements.driver")
    assert kernel_cache.carried((beam3,)) == {"beam3"}
    key = driver.rows_serial._cache._index_key((beam3,), driver.rows_serial.targetctx.codegen())
    assert key[-1] == (("beam3", kernel_cache.family_digest("beam3")),)
    assert not kernel_cache.outside({"beam2", "beam2_se3", "beam3"})
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
    from reference.io.deck import load_deck
    from reference.state import Record

    d = load_deck(Path(__file__).resolve().parent.parent / "models" / "three_bar.toml").domain
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
