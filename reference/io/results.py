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
renamed; records are appended in blocks, flushed at least every
``FLUSH_SECONDS``, so a run stopped in any way — even by SIGKILL — leaves a
file that opens, with the records up to its last flush.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import os
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
    "section_force": "elements/section_force",
    "section_moment": "elements/section_moment",
}
"""Record key → dataset path."""


def dataset_path(key: str) -> str:
    return DATASETS.get(key, key)


def _version() -> str:
    try:
        from flexmbs import __version__

        return __version__
    except ImportError:  # the engine does not need the application package
        return "unknown"


class ResultsWriter:
    """Incremental writer of one results file.

    Parameters
    ----------
    path : path-like
        File to create (parent folders are created; an older file of that name is replaced).
    domain, algorithm : optional
        Give the labels, ids and attributes (engine, algorithm, dt, deck …).
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
                 template=None):
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        if domain is not None:
            labels = [n.label for n in domain.nodes]
            items = {"joints": [j.label for j in domain.joints], "elements": [e.label for e in domain.elements]}
            ids = [n.id for n in domain.nodes]
            deck = domain.deck_text or ""
            attrs = {
                "engine": "flexmbs-reference", "engine_version": _version(), "deck": deck,
                "deck_sha256": hashlib.sha256(deck.encode("utf-8", "surrogatepass")).hexdigest(),
                "deck_path": str(domain.deck_path or ""), "algorithm": algorithm.name, "dt": algorithm.dt,
                **(attrs or {}),
            }
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
        self.f.attrs["flexmbs_version"] = _version()
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
        self._buffer: list[dict] = []
        self._bytes = 0
        self._flushed = time.monotonic()

    def _create(self, key: str, shape: tuple) -> None:
        name = dataset_path(key)
        if name in self.f or 0 in shape:
            return
        rows = max(1, min(256, (1 << 20) // (8 * max(1, int(np.prod(shape))))))
        self.f.create_dataset(name, shape=(0, *shape), maxshape=(None, *shape), chunks=(rows, *shape), dtype="f8")

    def append(self, entry: dict) -> None:
        """Append one output record (a dict of numbers and arrays, keys as in :data:`DATASETS`).

        Records are written in blocks, at least every ``FLUSH_SECONDS`` of wall
        time, every ``FLUSH_BYTES`` and on close (one HDF5 resize per record would
        cost milliseconds).
        """
        self._buffer.append(entry)
        self._bytes += sum(np.size(v) for v in entry.values()) * 8
        if self._bytes > FLUSH_BYTES or time.monotonic() - self._flushed > FLUSH_SECONDS:
            self.flush()

    def flush(self) -> None:
        """Write the buffered records and flush the file."""
        if self._buffer:
            n, k = self.n, len(self._buffer)
            for key in self._buffer[0]:
                block = np.array([e[key] for e in self._buffer], dtype=float)
                self._create(key, block.shape[1:])
                name = dataset_path(key)
                if name not in self.f:
                    continue
                ds = self.f[name]
                ds.resize((n + k, *ds.shape[1:]))
                ds[n:] = block
            self.n = n + k
            self._buffer, self._bytes = [], 0
        self.f.flush()
        self._flushed = time.monotonic()

    def close(self, status: str = "completed") -> None:
        """Write what is buffered, record ``status`` and close (safe to call twice)."""
        if self.f.id.valid:
            try:
                self.flush()
            finally:
                self.f.attrs["status"] = status
                self.f.close()

    def results(self, wall_time: float = 0.0):
        """The :class:`~reference.domain.Results` of this file, read on demand."""
        from reference.domain import Results

        return Results(source=self.path, wall_time=wall_time)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close("completed" if exc_type is None else f"failed: {exc_type.__name__}")


def load_results(path):
    """A results file (from either engine) as :class:`reference.domain.Results`; arrays are read on first use."""
    from reference.domain import Results

    return Results(source=Path(path))
