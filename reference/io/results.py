"""The results file (HDF5), the contract both engines honour.

Layout::

    /time (n,)   /nodes/id (N,)   /nodes/label (N,)
    /nodes/position (n,N,3)  /nodes/rotation (n,N,4)  /nodes/velocity (n,N,3)
    /nodes/angular_velocity (n,N,3)          (body frame)
    /constraints/violation_norm (n,)   /constraints/velocity_violation_norm (n,)
    /energy/kinetic, /energy/strain, /energy/external_work (n,)
    /energy/dissipated (n,)
    /constraints/multipliers (n,m)           Lagrange multipliers, M a + Bᵀλ = Q
    /joints/label (J,)   /joints/reaction_force (n,J,3)   /joints/reaction_moment (n,J,3)
                                             on body_i, about the joint point, inertial
    /joints/prescribed_reaction (n,J)        a prescribed displacement's force along its direction
    /elements/label (E,) /elements/section_force (n,E,3)  /elements/section_moment (n,E,3)
                                             midpoint, section frame

Every dataset is documented in ``docs/results.md``.  The per-item datasets are
written when there are items (J, E, m > 0); a reader treats a missing one as
"not computed".

Attributes: engine, engine_version, deck, deck_sha256, algorithm, dt, created,
flexmbs_version, status (``"running"`` while written, then ``"completed"``,
``"interrupted at t = …"``, ``"terminated at t = …"``, ``"diverged …"`` or
``"failed: …"``).

Every output record is a dict; :data:`DATASETS` maps its keys to dataset paths
(a key not listed is stored under its own name, so a new output is a new key of
the record and nothing else).  The file is valid from the moment it appears: it
is written under a temporary name with all datasets (empty) and flushed, then
renamed; records are appended in blocks, flushed by a timer thread within
``FLUSH_SECONDS`` of their append (also when no record follows, as in a run
stalled between two outputs), so a run stopped in any way — even by SIGKILL —
leaves a file that opens, with the records up to its last flush.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import importlib.metadata
import os
import threading
import time
from pathlib import Path

import h5py
import numpy as np

FLUSH_SECONDS = 0.5
FLUSH_BYTES = 16 * 2**20
"""A block is written at the latest when the buffered records reach this size."""
DATASETS = {
    "time": "time",
    "position": "nodes/position",
    "rotation": "nodes/rotation",
    "velocity": "nodes/velocity",
    "angular_velocity": "nodes/angular_velocity",
    "violation_norm": "constraints/violation_norm",
    "velocity_violation_norm": "constraints/velocity_violation_norm",
    "multipliers": "constraints/multipliers",
    "kinetic": "energy/kinetic",
    "strain": "energy/strain",
    "external_work": "energy/external_work",
    "dissipated": "energy/dissipated",
    "reaction_force": "joints/reaction_force",
    "reaction_moment": "joints/reaction_moment",
    "prescribed_reaction": "joints/prescribed_reaction",
    "section_force": "elements/section_force",
    "section_moment": "elements/section_moment",
    "negative_eigenvalues": "stability/negative_eigenvalues",
    "step_size": "solver/step_size",
    "steps": "solver/steps",
    "newton_iterations": "solver/newton_iterations",
    "residual_norm": "solver/residual_norm",
    "step_cuts": "solver/step_cuts",
    "factorizations": "solver/factorizations",
    "error_estimate": "solver/error_estimate",
    "steps_over_tolerance": "solver/steps_over_tolerance",
}
"""Record key → dataset path."""


def dataset_path(key: str) -> str:
    return DATASETS.get(key, key)


def version() -> str:
    """The installed flexmbs version (package metadata; ``"unknown"`` when run from a tree not installed)."""
    try:
        return importlib.metadata.version("flexmbs")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def deck_attrs(deck) -> dict:
    """The results file's attributes naming the deck (anything with ``path`` and ``text``; None: no deck)."""
    text = "" if deck is None else deck.text
    return {"deck": text, "deck_sha256": hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest(),
            "deck_path": "" if deck is None else str(deck.path)}


class ResultsWriter:
    """Incremental writer of one results file.

    Parameters
    ----------
    path : path-like
        File to create (parent folders are created; an older file of that name is replaced).
    domain, algorithm : optional
        Give the labels, ids and attributes (engine, algorithm, dt).
    deck : optional
        With a domain: the deck it was read from (:class:`reference.io.deck.Deck`), recorded
        in the attributes ``deck``, ``deck_sha256``, ``deck_path``.
    labels, ids : sequences
        Node labels and stable ids (without a domain).
    items : dict, optional
        Labels of the joints and elements (``{"joints": [...], "elements": [...]}``);
        taken from the domain when one is given.
    attrs : dict
        Further file attributes.
    template : dict, optional
        A record of the right shapes: its datasets are created (empty) with the file.
        Without one, the node and scalar datasets of the layout are created and any
        other key gets its dataset at its first block.
    """

    def __init__(self, path, domain=None, algorithm=None, *, labels=None, ids=None, attrs=None, items=None,
                 template=None, deck=None):
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        if domain is not None:
            labels = [n.label for n in domain.nodes]
            items = {"joints": [j.label for j in domain.joints], "elements": [e.label for e in domain.elements]}
            ids = [n.id for n in domain.nodes]
            attrs = {"engine": "flexmbs-reference", "engine_version": version(), **deck_attrs(deck),
                     "algorithm": algorithm.name, "dt": algorithm.dt, **(attrs or {})}
        self.path = path
        self.n_nodes = len(labels)
        if template is None:
            template = {"time": 0.0, **{k: np.zeros((self.n_nodes, w)) for k, w in
                                        (("position", 3), ("rotation", 4), ("velocity", 3), ("angular_velocity", 3))},
                        **{k: 0.0 for k in ("violation_norm", "velocity_violation_norm", "kinetic", "strain",
                                            "external_work", "dissipated")}}
        partial = path.with_name(path.name + ".part")
        path.unlink(missing_ok=True)
        partial.unlink(missing_ok=True)
        self.f = h5py.File(partial, "w")
        self.f.attrs.update({k: v for k, v in (attrs or {}).items()})
        self.f.attrs["created"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        self.f.attrs["flexmbs_version"] = version()
        self.f.attrs["status"] = "running"
        self.f.create_dataset("nodes/id", data=np.asarray(ids, dtype=np.int64))
        self.f.create_dataset("nodes/label", data=np.array(labels, dtype=h5py.string_dtype()))
        for group, names in (items or {}).items():
            self.f.create_dataset(f"{group}/label", data=np.array(list(names), dtype=h5py.string_dtype()))
        for key, value in template.items():
            self._create(key, np.asarray(value, dtype=float).shape)
        self.f.flush()
        os.replace(partial, path)  # the file appears complete, header and empty datasets
        self.n = 0
        self._block: dict[str, np.ndarray] = {}
        self._rows = 0
        self._flushed = time.monotonic()
        self._lock, self._closing = threading.Lock(), threading.Event()
        self._timer = threading.Thread(target=self._flush_on_time, name="results flush", daemon=True)
        self._timer.start()

    def _flush_on_time(self) -> None:
        """The timer thread: every ``FLUSH_SECONDS / 4``, write the buffered records whose last flush is
        ``FLUSH_SECONDS`` old, so that a record is on disk at most about ``FLUSH_SECONDS`` after its append
        even when no append follows (a stalled run killed by SIGKILL keeps it).  It runs whenever the main
        thread is in Python (the compiled stepping calls return within a fraction of a second,
        :class:`reference.algorithms.base.CallBudget`); h5py serialises the HDF5 calls of both threads,
        :attr:`_lock` the block.  Ends with :meth:`close`."""
        while not self._closing.wait(FLUSH_SECONDS / 4):
            with self._lock:
                if self._rows and self.f.id.valid and time.monotonic() - self._flushed >= FLUSH_SECONDS:
                    self._flush()

    def _create(self, key: str, shape: tuple) -> None:
        name = dataset_path(key)
        if name in self.f or 0 in shape:
            return
        rows = max(1, min(256, (1 << 20) // (8 * max(1, int(np.prod(shape))))))
        self.f.create_dataset(name, shape=(0, *shape), maxshape=(None, *shape), chunks=(rows, *shape), dtype="f8")

    def append(self, entry: dict) -> None:
        """Append one output record (a dict of numbers and arrays, keys as in :data:`DATASETS`).

        The values are copied at once (the caller may reuse its arrays) into a block of
        preallocated rows, written at the latest when the buffered records exceed
        ``FLUSH_BYTES``, every ``FLUSH_SECONDS`` of wall time and on close (one HDF5
        resize per record would cost milliseconds).  The first record fixes the keys and shapes.
        """
        with self._lock:
            if not self._block:
                shapes = {k: np.shape(v) for k, v in entry.items()}
                size = sum(int(np.prod(s)) for s in shapes.values()) * 8
                capacity = FLUSH_BYTES // max(size, 1) + 1
                self._block = {k: np.empty((capacity, *s)) for k, s in shapes.items()}
            k = self._rows
            for key, block in self._block.items():
                block[k] = entry[key]
            self._rows = k + 1
            if self._rows == next(iter(self._block.values())).shape[0] or \
                    time.monotonic() - self._flushed > FLUSH_SECONDS:
                self._flush()

    def flush(self) -> None:
        """Write the buffered records and flush the file."""
        with self._lock:
            self._flush()

    def _flush(self) -> None:
        """:meth:`flush`, the lock held."""
        if self._rows:
            n, k = self.n, self._rows
            for key, block in self._block.items():
                self._create(key, block.shape[1:])
                name = dataset_path(key)
                if name not in self.f:
                    continue
                ds = self.f[name]
                ds.resize((n + k, *ds.shape[1:]))
                ds[n:] = block[:k]
            self.n = n + k
            self._rows = 0
        self.f.flush()
        self._flushed = time.monotonic()

    def add_datasets(self, datasets: dict) -> None:
        """Write datasets that are not time histories (path → array, e.g. ``"modes/frequency"``); an
        existing one of that path is replaced."""
        with self._lock:
            for path, value in datasets.items():
                if path in self.f:
                    del self.f[path]
                value = np.asarray(value)
                self.f.create_dataset(path, data=value.astype(h5py.string_dtype()) if value.dtype.kind == "U"
                                      else value)
            if datasets:
                self.f.flush()

    def close(self, status: str = "completed") -> None:
        """Write what is buffered, record ``status`` and close (safe to call twice); the timer thread ends."""
        self._closing.set()
        with self._lock:
            if self.f.id.valid:
                try:
                    self._flush()
                finally:
                    self.f.attrs["status"] = status
                    self.f.close()

    def results(self, wall_time: float = 0.0):
        """The :class:`Results` of this file, read on demand."""
        return Results(source=self.path, wall_time=wall_time)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close("completed" if exc_type is None else f"failed: {exc_type.__name__}")


def append_datasets(path, datasets: dict) -> None:
    """Write ``datasets`` (HDF5 path → array) into the closed results file at ``path``, replacing any of the same
    path: the sensitivities of a run (:func:`reference.io.deck_sensitivities.sensitivity_datasets`), computed
    after it."""
    with h5py.File(path, "a") as f:
        for key, value in datasets.items():
            if key in f:
                del f[key]
            f.create_dataset(key, data=np.asarray(value))


def load_results(path):
    """A results file (from either engine) as :class:`Results`; arrays are read on first use."""
    return Results(source=Path(path))


class Results:
    """Time histories of a run, from the results file (read on demand) or from memory.

    ``time`` (n,), ``positions``/``velocities``/``angular_velocities`` (n,N,3),
    ``rotations`` (n,N,4), ``energy`` dict of (n,) arrays, ``constraint_violation``,
    ``velocity_constraint_violation`` (n,), ``labels`` (N,), ``status`` ("completed"
    or why the run stopped), ``wall_time`` [s], ``attrs`` (the file's attributes).
    Joints (J): ``joint_labels``, ``reaction_forces`` and ``reaction_moments``
    (n,J,3), the force and the moment about the joint point that each joint
    exerts on its body_i, inertial [N], [N m] (NaN where not computed:
    master/slave joints).  Elements (E): ``element_labels`` (``"beam/i"``),
    ``section_forces``/``section_moments`` (n,E,3) at the midpoint, section
    frame.  ``multipliers`` (n,m) the Lagrange multipliers (``M a + Bᵀλ = Q``).

    Node keys are ids, labels, or the aliases ``BEAM:start`` and ``BEAM:end``
    (the first and last node ``BEAM:i`` of a meshed beam).  ``position("beam:12")``
    and the like read one node's history (from a file, only that node's column);
    :meth:`data` gives any dataset by its path in the file.

    Parameters
    ----------
    source : path, optional
        A results file: the arrays not given are read from it on first use, so a
        long run's histories are not held in memory unless asked for.
    **arrays
        The histories given, by their names above (:attr:`ARRAYS`' keys and ``energy``).
    """

    ARRAYS = {
        "time": "time", "positions": "nodes/position", "rotations": "nodes/rotation",
        "velocities": "nodes/velocity", "angular_velocities": "nodes/angular_velocity",
        "constraint_violation": "constraints/violation_norm",
        "velocity_constraint_violation": "constraints/velocity_violation_norm",
        "reaction_forces": "joints/reaction_force", "reaction_moments": "joints/reaction_moment",
        "section_forces": "elements/section_force", "section_moments": "elements/section_moment",
        "multipliers": "constraints/multipliers",
    }
    """Attribute → dataset path in the results file."""
    ENERGIES = ("kinetic", "strain", "external_work", "dissipated")
    WIDTHS = {"joints/reaction_force": "joint_labels", "joints/reaction_moment": "joint_labels",
              "elements/section_force": "element_labels", "elements/section_moment": "element_labels"}
    """Per-item datasets (n, items, 3): NaN of that shape when a file lacks them."""

    def __init__(self, *, labels=None, status: str = "completed", wall_time: float = 0.0, attrs=None,
                 joint_labels=None, element_labels=None, source=None, extra=None, **arrays):
        unknown = sorted(set(arrays) - set(self.ARRAYS) - {"energy"})
        if unknown:
            raise TypeError(f"Results got unknown histories {unknown}; known: {sorted(self.ARRAYS)} and energy")
        self.__dict__.update({k: v for k, v in arrays.items() if v is not None})
        self.source = source
        self.extra = dict(extra or {})
        self.wall_time = wall_time
        self.labels, self.status, self.attrs = labels, status, dict(attrs or {})
        self.joint_labels, self.element_labels = list(joint_labels or []), list(element_labels or [])
        if source is not None:
            import h5py

            def names(f, name):
                return [s.decode() if isinstance(s, bytes) else str(s) for s in f[name][()]] if name in f else []

            with h5py.File(source, "r") as f:
                self.labels = names(f, "nodes/label")
                self.joint_labels, self.element_labels = names(f, "joints/label"), names(f, "elements/label")
                self.attrs = dict(f.attrs)
                self.status = str(f.attrs.get("status", ""))

    def __getattr__(self, name):
        if name.startswith("__") or name in ("source", "extra"):
            raise AttributeError(name)
        if name == "energy":
            value = {k: self.data(f"energy/{k}") for k in self.ENERGIES}
        elif name in self.ARRAYS:
            value = self.data(self.ARRAYS[name])
        else:
            raise AttributeError(name)
        self.__dict__[name] = value
        return value

    def data(self, path: str, index=()) -> np.ndarray:
        """The dataset at ``path`` (e.g. ``"constraints/multipliers"``, ``"modes/frequency"``), or its
        ``[:, index]`` part (text as ``str``); NaN (zero columns for the multipliers) where the run did
        not compute it."""
        if path in self.extra:
            return self.extra[path][(slice(None), *np.atleast_1d(index))] if index != () else self.extra[path]
        if self.source is None:
            n = len(self.time)
            return self._missing(path, n)
        import h5py

        with h5py.File(self.source, "r") as f:
            if path not in f:
                return self._missing(path, f["time"].shape[0])
            ds = f[path].asstr() if h5py.check_string_dtype(f[path].dtype) else f[path]
            return np.asarray(ds[(slice(None), index)] if index != () else ds[()])

    def _missing(self, path: str, n: int) -> np.ndarray:
        if path == "constraints/multipliers":
            return np.zeros((n, 0))
        if path in self.WIDTHS:
            return np.full((n, len(getattr(self, self.WIDTHS[path])), 3), np.nan)
        return np.full(n, np.nan)

    def __len__(self) -> int:
        return len(self.time)

    def index(self, key) -> int:
        """Column of a node: an id, a label, or ``BEAM:start`` / ``BEAM:end``."""
        if isinstance(key, (int, np.integer)):
            return int(key)
        if key in self.labels:
            return self.labels.index(key)
        beam, _, which = str(key).rpartition(":")
        if which in ("start", "end"):
            numbered = [(int(lbl.rpartition(":")[2]), k) for k, lbl in enumerate(self.labels)
                        if lbl.rpartition(":")[0] == beam and lbl.rpartition(":")[2].isdigit()]
            if numbered:
                return (min if which == "start" else max)(numbered)[1]
        raise KeyError(f"no node labelled {key!r}; labels are e.g. {self.labels[:4]}")

    def _node(self, name: str, key) -> np.ndarray:
        if name in self.__dict__ or self.source is None:
            return getattr(self, name)[:, self.index(key)]
        return self.data(self.ARRAYS[name], self.index(key))

    def position(self, key) -> np.ndarray:
        return self._node("positions", key)

    def rotation(self, key) -> np.ndarray:
        return self._node("rotations", key)

    def velocity(self, key) -> np.ndarray:
        return self._node("velocities", key)

    def angular_velocity(self, key) -> np.ndarray:
        return self._node("angular_velocities", key)

    def joint_index(self, joint) -> int:
        if joint in self.joint_labels:
            return self.joint_labels.index(joint)
        raise KeyError(f"no joint labelled {joint!r}; joints are {self.joint_labels}")

    def element_index(self, beam, element=None) -> int:
        """Column of an element: its label ``"beam/i"``, or ``(beam, i)``."""
        label = str(beam) if element is None else f"{beam}/{int(element)}"
        if label in self.element_labels:
            return self.element_labels.index(label)
        raise KeyError(f"no element labelled {label!r}; elements are e.g. {self.element_labels[:4]}")

    def reaction(self, joint) -> tuple[np.ndarray, np.ndarray]:
        """``(force, moment)`` (n, 3) each: what ``joint`` exerts on its body_i, moment about the
        joint point, inertial components [N], [N m]."""
        k = self.joint_index(joint)
        return self.reaction_forces[:, k], self.reaction_moments[:, k]

    def section_force(self, beam, element=None) -> np.ndarray:
        """Force resultant N (n, 3) at the midpoint of element ``beam/element``, section frame [N]."""
        return self.section_forces[:, self.element_index(beam, element)]

    def section_moment(self, beam, element=None) -> np.ndarray:
        """Moment resultant M (n, 3) at the midpoint of element ``beam/element``, section frame [N m]."""
        return self.section_moments[:, self.element_index(beam, element)]


class MemoryRecorder:
    """Keeps the records of a run in preallocated arrays (``Domain.solve`` without a results file).

    Parameters
    ----------
    capacity : int
        Number of records the run will take.
    labels : list
        Node labels.
    """

    def __init__(self, capacity: int, labels: list, joint_labels=(), element_labels=()):
        self.capacity, self.labels, self.n = capacity, labels, 0
        self.joint_labels, self.element_labels = list(joint_labels), list(element_labels)
        self.arrays: dict[str, np.ndarray] = {}
        self.datasets: dict[str, np.ndarray] = {}

    def append(self, entry: dict) -> None:
        if not self.arrays:
            self.arrays = {k: np.empty((self.capacity, *np.shape(v))) for k, v in entry.items()}
        for k, v in entry.items():
            self.arrays[k][self.n] = v
        self.n += 1

    def add_datasets(self, datasets: dict) -> None:
        """Keep datasets that are not time histories (path → array), read back by :meth:`Results.data`."""
        self.datasets.update({path: np.asarray(value) for path, value in datasets.items()})

    def close(self, status: str) -> None:
        self.status = status

    def results(self, wall_time: float = 0.0) -> Results:
        from reference.io.results import dataset_path

        by_path = {dataset_path(k): a[: self.n] for k, a in self.arrays.items()}
        fields = {name: by_path.pop(path) for name, path in Results.ARRAYS.items() if path in by_path}
        energy = {k: by_path.pop(f"energy/{k}", np.full(self.n, np.nan)) for k in Results.ENERGIES}
        return Results(labels=self.labels, energy=energy, status=self.status, wall_time=wall_time,
                       extra={**by_path, **self.datasets},
                       joint_labels=self.joint_labels, element_labels=self.element_labels, **fields)
