"""Where numba keeps an engine kernel compiled, and what makes that copy stale.

numba's own on-disk cache checks only the source file that defines a function.  An engine kernel inlines
functions of other files (the time functions of :mod:`reference.interactions` into the explicit step, the
element families into every algorithm), so an edit there would leave it running the old code.  Here an
engine kernel's cached copy is keyed by the sources it can reach:

* its **import closure**: the defining module and every engine module it imports, directly or through other
  engine modules, read from the ``import`` statements of the files (:func:`closure`).  An edit of the deck
  reader, the Domain or another algorithm leaves a kernel whose closure does not hold them warm;
* the **element families** it is compiled for.  A family's module (``reference/elements/beam3.py`` and what
  it imports) is left out of the closures of the modules that reach it only through the registry
  (:mod:`reference.elements.families`); instead, the digest of each family the kernel's argument types carry
  enters the key of that compiled version (:meth:`EngineCache._index_key`).  A model of Beam2 elements only
  does not carry beam3's data, so editing the beam3 family leaves its kernels warm, and a beam3 model's
  kernels compile again.  The generic element driver's kernels (:mod:`reference.elements.driver`), compiled
  for one family's data at a time, are keyed by the digest of that family likewise.

A kernel compiled for the data of a family registered from outside the engine (a test's toy family) is not
written to the disk cache at all (:func:`outside`): another process, which cannot import that family's
module, could not read the cache's index.

The copies live below ``$NUMBA_CACHE_DIR``, or ``$XDG_CACHE_HOME/flexmbs/numba`` (``~/.cache/…`` without it),
in one folder per source folder of each checkout (two checkouts do not overwrite each other's copies).
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import os
import re
from pathlib import Path

from numba import types
from numba.core.caching import CompileResultCacheImpl, FunctionCache, _CacheLocator

ENGINE = Path(__file__).resolve().parent
"""The engine's package folder: the modules whose imports are followed."""

ROOT = Path(os.environ.get("NUMBA_CACHE_DIR") or Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
            / "flexmbs" / "numba")
"""The folder of every cached kernel."""

FAMILY_TAG = "flexmbs_family_"
"""The prefix of the record field that marks a family's data in a kernel's plain argument types
(:data:`reference.jit.TAG`, set by :func:`reference.elements.families.register`)."""

_FROM = re.compile(r"^\s*from\s+(reference[\w.]*)\s+import\s+(\([^)]*\)|[^\n#]*)", re.M)
_IMPORT = re.compile(r"^\s*import\s+(reference[\w.]*)", re.M)
_FAMILY = re.compile(r"^\s+family\s*=\s*[\"']", re.M)


@functools.cache
def modules() -> dict[str, Path]:
    """Every engine module's dotted name → its file (a package's name → its ``__init__.py``)."""
    found = {}
    for path in ENGINE.rglob("*.py"):
        parts = ("reference",) + path.relative_to(ENGINE).with_suffix("").parts
        found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


@functools.cache
def imports(name: str) -> frozenset[str]:
    """The engine modules that module ``name`` imports, anywhere in its file (``from A import b`` counts A,
    and A.b where that is a module)."""
    known, text = modules(), modules()[name].read_text(encoding="utf-8")
    found = {m for m in _IMPORT.findall(text) if m in known}
    for base, names in _FROM.findall(text):
        if base in known:
            found.add(base)
        for item in re.findall(r"\w+", names.split(" as ")[0] if "(" not in names else names):
            if f"{base}.{item}" in known:
                found.add(f"{base}.{item}")
    found.discard(name)
    return frozenset(found)


@functools.cache
def family_modules() -> frozenset[str]:
    """The modules that define an element family (a class with a ``family = "…"`` attribute, below
    ``reference/elements``)."""
    return frozenset(name for name, path in modules().items()
                     if name.startswith("reference.elements.") and _FAMILY.search(path.read_text(encoding="utf-8")))


REGISTRY = "reference.elements.families"
"""The module that imports every element family to register it: its imports of the families are not followed."""


@functools.cache
def closure(name: str) -> frozenset[str]:
    """Module ``name`` and every engine module it reaches by imports, but for the element families that it
    reaches only through the registry (:data:`REGISTRY`)."""
    seen, todo = set(), [name]
    while todo:
        module = todo.pop()
        if module not in seen:
            seen.add(module)
            todo += [m for m in imports(module) if module != REGISTRY or m not in family_modules()]
    return frozenset(seen)


@functools.cache
def digest(name: str) -> str:
    """SHA-256 (16 hex digits) of the names and contents of :func:`closure` ``(name)``."""
    h = hashlib.sha256()
    for module in sorted(closure(name)):
        h.update(module.encode())
        h.update(modules()[module].read_bytes())
    return h.hexdigest()[:16]


@functools.cache
def module_of(path: str | Path) -> str | None:
    """The engine module defined by the file ``path``, or None outside the engine."""
    by_file = {file: name for name, file in modules().items()}
    return by_file.get(Path(path).resolve())


def _families_in(typ, found: set, by_data: dict) -> None:
    """Add the deck names of the element families whose data the numba type ``typ`` carries (``by_data``: a
    family's data class → its name)."""
    if isinstance(typ, types.BaseNamedTuple) and typ.instance_class in by_data:
        found.add(by_data[typ.instance_class])
    if isinstance(typ, types.BaseTuple):
        for item in typ.types:
            _families_in(item, found, by_data)
    elif isinstance(typ, types.Array) and isinstance(typ.dtype, types.Record):
        found.update(field[len(FAMILY_TAG):] for field in typ.dtype.fields if field.startswith(FAMILY_TAG))


FAMILIES: dict[str, type] = {}
"""The registered element families' formulation classes by deck name (filled by
:func:`reference.elements.families.register`, which tells this module of each)."""
ALWAYS: set[str] = set()
"""The families every Model carries (:data:`reference.elements.families.ALWAYS_PACKED`)."""


def carried(signature) -> set[str]:
    """The element families (deck names) whose data a compiled version's argument types carry."""
    found, by_data = set(), {f.Data: name for name, f in FAMILIES.items()}
    for typ in getattr(signature, "args", signature) or ():
        _families_in(typ, found, by_data)
    return found


def families_in(signature) -> set[str]:
    """:func:`carried` and the families every Model carries (:data:`ALWAYS`)."""
    return carried(signature) | ALWAYS


def family_digest(family: str) -> str:
    """:func:`digest` of the module that defines the registered element family ``family``."""
    formulation = FAMILIES[family]
    module = formulation.__module__
    if module in modules():
        return digest(module)
    # a family registered from outside the engine: its own file
    return hashlib.sha256(Path(inspect.getfile(formulation)).read_bytes()).hexdigest()[:16]


class EngineLocator(_CacheLocator):
    """numba's cache locator for a function defined in the engine: the folder below :data:`ROOT`, and as
    the source stamp the :func:`digest` of its module's closure."""

    def __init__(self, py_func, py_file):
        self._module = module_of(py_file)
        self._lineno = py_func.__code__.co_firstlineno
        self._path = str(ROOT / self.get_suitable_cache_subpath(py_file))

    def get_cache_path(self) -> str:
        return self._path

    def get_source_stamp(self) -> str:
        return digest(self._module)

    def get_disambiguator(self) -> str:
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        if module_of(py_file) is None:
            return None
        locator = cls(py_func, py_file)
        try:
            locator.ensure_cache_path()
        except OSError:
            return None
        return locator


class _EngineImpl(CompileResultCacheImpl):
    _locator_classes = [EngineLocator]


def outside(families: set[str]) -> bool:
    """True where one of ``families`` is registered from outside the engine (e.g. a test's toy family): a
    kernel compiled for its data is not cached on disk, where other processes, which cannot import the
    family's module, would find it in the cache's index and fail to read the index."""
    return any(FAMILIES[name].__module__ not in modules() for name in families if name in FAMILIES)


class EngineCache(FunctionCache):
    """numba's function cache, located by :class:`EngineLocator`, whose index key of each compiled version also
    holds the digests of the element families of its argument types (all of them when its module reaches the
    family registry, module docstring; those its arguments carry otherwise, e.g. the generic element driver's
    kernels).  A version compiled for a family from outside the engine is neither saved nor looked up
    (:func:`outside`)."""

    _impl_class = _EngineImpl

    def __init__(self, py_func):
        super().__init__(py_func)
        self._module = module_of(inspect.getfile(py_func))

    def _index_key(self, sig, codegen):
        key = super()._index_key(sig, codegen)
        families = families_in(sig) if REGISTRY in closure(self._module) else carried(sig)
        if not families:
            return key
        return key + (tuple((name, family_digest(name)) for name in sorted(families)),)

    def load_overload(self, sig, target_context):
        return None if outside(carried(sig)) else super().load_overload(sig, target_context)

    def save_overload(self, sig, data):
        if not outside(carried(sig)):
            super().save_overload(sig, data)


def enable(dispatcher):
    """Cache the numba ``dispatcher`` on disk: an engine function's by :class:`EngineCache`, any other
    function's by numba's own cache; returns it (with ``NUMBA_DISABLE_JIT=1``, the plain function)."""
    if not hasattr(dispatcher, "py_func"):
        return dispatcher
    if module_of(inspect.getfile(dispatcher.py_func)) is not None:
        dispatcher._cache = EngineCache(dispatcher.py_func)
    else:
        dispatcher.enable_caching()
    return dispatcher
