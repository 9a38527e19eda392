"""The results file (HDF5), the contract both engines honour.

Layout::

    /time (n,)   /nodes/id (N,)   /nodes/label (N,)
    /nodes/position (n,N,3)  /nodes/rotation (n,N,4)  /nodes/velocity (n,N,3)
    /nodes/angular_velocity (n,N,3)          (body frame)
    /constraints/violation_norm (n,)   /constraints/velocity_violation_norm (n,)
    /energy/kinetic, /energy/strain, /energy/external_work (n,)
    /energy/dissipated (n,)                  (extra: damping, when present)
    /constraints/multipliers (n,m)           Lagrange multipliers, M a + Bᵀλ = Q
    /joints/label (J,)   /joints/reaction_force (n,J,3)   /joints/reaction_moment (n,J,3)
                                             on body_i, about the joint point, inertial
    /elements/label (E,) /elements/section_force (n,E,3)  /elements/section_moment (n,E,3)
                                             midpoint, section frame

Every dataset is documented in ``docs/results.md``.  The per-item datasets
(``ITEM_FIELDS``) are written when there are items (J, E, m > 0); a reader
treats a missing one as "not computed".

Attributes: engine, engine_version, deck, deck_sha256, algorithm, dt, created,
flexmbs_version, status (``"running"`` while written, then ``"completed"`` or
why the run stopped).  Datasets are chunked and resizable and every record is
written as it comes; the file is flushed at least every ``FLUSH_SECONDS`` and
on close, so a run that stops — even by a hard kill — leaves a valid file.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import time
from pathlib import Path

import h5py
import numpy as np

FLUSH_SECONDS = 0.5
NODE_FIELDS = {"position": 3, "rotation": 4, "velocity": 3, "angular_velocity": 3}
SCALARS = {
    "constraints/violation_norm": "violation_norm",
    "constraints/velocity_violation_norm": "velocity_violation_norm",
    "energy/kinetic": "kinetic",
    "energy/strain": "strain",
    "energy/external_work": "external_work",
    "energy/dissipated": "dissipated",
}
ITEM_FIELDS = {
    "joints/reaction_force": ("joints", "reaction_force", 3),
    "joints/reaction_moment": ("joints", "reaction_moment", 3),
    "elements/section_force": ("elements", "section_force", 3),
    "elements/section_moment": ("elements", "section_moment", 3),
}
"""Per-item datasets (n, items, width): HDF5 name → (item group, record key, width)."""
ROW_FIELDS = {"constraints/multipliers": "multipliers"}
"""Per-record vectors (n, m): HDF5 name → record key (width taken from the first record)."""


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
        File to create (parent folders are created).
    labels, ids : sequences
        Node labels and stable ids.
    items : dict, optional
        Labels of the joints and elements (``{"joints": [...], "elements": [...]}``);
        taken from the domain when one is given.
    attrs : dict
        File attributes (engine, algorithm, dt, deck …).
    """

    def __init__(self, path, domain=None, algorithm=None, *, labels=None, ids=None, attrs=None, items=None):
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        if domain is not None:
            labels = [n.label for n in domain.nodes]
            items = {"joints": [j.label for j in domain.joints], "elements": [e.label for e in domain.elements]}
            ids = [n.id for n in domain.nodes]
            deck = domain.deck_text or ""
            attrs = {
                "engine": "flexmbs-reference", "engine_version": _version(), "deck": deck,
                "deck_sha256": hashlib.sha256(deck.encode()).hexdigest(),
                "deck_path": str(domain.deck_path or ""), "algorithm": algorithm.name, "dt": algorithm.dt,
                **(attrs or {}),
            }
        self.n_nodes = len(labels)
        self.f = h5py.File(path, "w")
        self.f.attrs.update({k: v for k, v in (attrs or {}).items()})
        self.f.attrs["created"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        self.f.attrs["flexmbs_version"] = _version()
        self.f.attrs["status"] = "running"
        self.f.create_dataset("nodes/id", data=np.asarray(ids, dtype=np.int64))
        self.f.create_dataset("nodes/label", data=np.array(labels, dtype=h5py.string_dtype()))
        self.f.create_dataset("time", shape=(0,), maxshape=(None,), chunks=(256,), dtype="f8")
        for name, width in NODE_FIELDS.items():
            self.f.create_dataset(f"nodes/{name}", shape=(0, self.n_nodes, width),
                                  maxshape=(None, self.n_nodes, width), chunks=(16, self.n_nodes, width), dtype="f8")
        for name in SCALARS:
            self.f.create_dataset(name, shape=(0,), maxshape=(None,), chunks=(256,), dtype="f8")
        self.items = {k: list(v) for k, v in (items or {}).items()}
        for group, names in self.items.items():
            self.f.create_dataset(f"{group}/label", data=np.array(names, dtype=h5py.string_dtype()))
        for name, (group, _, width) in ITEM_FIELDS.items():
            count = len(self.items.get(group, []))
            if count:
                self.f.create_dataset(name, shape=(0, count, width), maxshape=(None, count, width),
                                      chunks=(16, count, width), dtype="f8")
        self.n = 0
        self._buffer = []
        self._flushed = time.monotonic()

    def append(self, entry: dict) -> None:
        """Append one output record (keys: time, the node fields, the scalar names).

        Records are written in blocks, at least every ``FLUSH_SECONDS`` of wall
        time and on close (one HDF5 resize per record would cost milliseconds).
        """
        self._buffer.append(entry)
        if time.monotonic() - self._flushed > FLUSH_SECONDS:
            self.flush()

    def flush(self) -> None:
        """Write the buffered records and flush the file."""
        if self._buffer:
            n, k = self.n, len(self._buffer)
            self.f["time"].resize((n + k,))
            self.f["time"][n:] = [e["time"] for e in self._buffer]
            for name in NODE_FIELDS:
                ds = self.f[f"nodes/{name}"]
                ds.resize((n + k, self.n_nodes, ds.shape[2]))
                ds[n:] = np.array([e[name] for e in self._buffer])
            for name, key in SCALARS.items():
                ds = self.f[name]
                ds.resize((n + k,))
                ds[n:] = [e.get(key, np.nan) for e in self._buffer]
            for name, (_, key, width) in ITEM_FIELDS.items():
                if name in self.f:
                    ds = self.f[name]
                    ds.resize((n + k,) + ds.shape[1:])
                    ds[n:] = np.array([e.get(key, np.full(ds.shape[1:], np.nan)) for e in self._buffer])
            for name, key in ROW_FIELDS.items():
                width = len(np.atleast_1d(self._buffer[0].get(key, [])))
                if name not in self.f and width and n == 0:
                    self.f.create_dataset(name, shape=(0, width), maxshape=(None, width),
                                          chunks=(max(1, 4096 // width), width), dtype="f8")
                if name in self.f:
                    ds = self.f[name]
                    ds.resize((n + k, ds.shape[1]))
                    ds[n:] = np.array([e.get(key, np.full(ds.shape[1], np.nan)) for e in self._buffer])
            self.n = n + k
            self._buffer = []
        self.f.flush()
        self._flushed = time.monotonic()

    def close(self, status: str = "completed") -> None:
        if self.f.id.valid:
            self.flush()
            self.f.attrs["status"] = status
            self.f.close()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close("completed" if exc_type is None else f"stopped: {exc_type.__name__}")


def load_results(path):
    """Read a results file (from either engine) into :class:`reference.domain.Results`."""
    from reference.domain import Results

    def names(name):
        return [s.decode() if isinstance(s, bytes) else str(s) for s in f[name][()]] if name in f else []

    with h5py.File(path, "r") as f:
        labels = names("nodes/label")
        scal = {key: f[name][()] if name in f else np.full(f["time"].shape, np.nan) for name, key in SCALARS.items()}
        n = f["time"].shape[0]
        items = {"joints": names("joints/label"), "elements": names("elements/label")}
        fields = {key: f[name][()] if name in f else np.full((n, len(items[group]), width), np.nan)
                  for name, (group, key, width) in ITEM_FIELDS.items()}
        return Results(
            time=f["time"][()], labels=labels, positions=f["nodes/position"][()],
            rotations=f["nodes/rotation"][()], velocities=f["nodes/velocity"][()],
            angular_velocities=f["nodes/angular_velocity"][()],
            energy={k: scal[k] for k in ("kinetic", "strain", "external_work", "dissipated")},
            constraint_violation=scal["violation_norm"],
            velocity_constraint_violation=scal["velocity_violation_norm"],
            status=str(f.attrs.get("status", "")), attrs=dict(f.attrs),
            joint_labels=items["joints"], reaction_forces=fields["reaction_force"],
            reaction_moments=fields["reaction_moment"], element_labels=items["elements"],
            section_forces=fields["section_force"], section_moments=fields["section_moment"],
            multipliers=f["constraints/multipliers"][()] if "constraints/multipliers" in f else np.zeros((n, 0)),
        )
