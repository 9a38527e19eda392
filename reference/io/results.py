"""The results file (HDF5), the contract both engines honour.

Layout::

    /time (n,)   /nodes/id (N,)   /nodes/label (N,)
    /nodes/position (n,N,3)  /nodes/rotation (n,N,4)  /nodes/velocity (n,N,3)
    /nodes/angular_velocity (n,N,3)          (body frame)
    /constraints/violation_norm (n,)   /constraints/velocity_violation_norm (n,)
    /energy/kinetic, /energy/strain, /energy/external_work (n,)
    /energy/dissipated (n,)                  (extra: damping, when present)

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
    attrs : dict
        File attributes (engine, algorithm, dt, deck …).
    """

    def __init__(self, path, domain=None, algorithm=None, *, labels=None, ids=None, attrs=None):
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        if domain is not None:
            labels = [n.label for n in domain.nodes]
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

    with h5py.File(path, "r") as f:
        labels = [s.decode() if isinstance(s, bytes) else str(s) for s in f["nodes/label"][()]]
        scal = {key: f[name][()] if name in f else np.full(f["time"].shape, np.nan) for name, key in SCALARS.items()}
        return Results(
            time=f["time"][()], labels=labels, positions=f["nodes/position"][()],
            rotations=f["nodes/rotation"][()], velocities=f["nodes/velocity"][()],
            angular_velocities=f["nodes/angular_velocity"][()],
            energy={k: scal[k] for k in ("kinetic", "strain", "external_work", "dissipated")},
            constraint_violation=scal["violation_norm"],
            velocity_constraint_violation=scal["velocity_violation_norm"],
            status=str(f.attrs.get("status", "")), attrs=dict(f.attrs),
        )
