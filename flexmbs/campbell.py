"""``flexmbs campbell``: the frequencies of a model in steady rotation over a range of spin rates.

A modes deck with ``about = "rotation"`` (docs/deck.md) gives the spin axis, the point on it and the
number of modes; the command solves the deck as ``flexmbs modes`` does (its own spin rate), then, for each
rate of ``--rates START:STOP:N`` (N equally spaced rates [rad/s]), the relative equilibrium and the modes in
the spinning frame (:func:`reference.algorithms.linearization.at_steady_rotation`, :func:`reference.modal.modes`), each
rate starting Newton from the stretched state of the one before.  The modes are sorted by frequency at
every rate (no tracking of a mode through a crossing).  The table goes to the terminal, the datasets
``/campbell/spin_rate`` [rad/s], ``/campbell/frequency`` [Hz], ``/campbell/damping_ratio`` and
``/campbell/kind`` to the results file (docs/results.md), the figure to ``campbell.png`` beside it.

Why a command of its own rather than ``flexmbs sweep``: a sweep runs every case as an independent deck
from the reference state, into its own results file, whereas a Campbell diagram is one curve per mode
over the rates, in one file and one figure, and each rate is cheap once the previous rate's stretched
state is known.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Campbell:
    """The modes over the spin rates: ``spin_rate`` (k,) [rad/s]; ``frequency``, ``damping_ratio``, ``kind``
    (k, n); ``shapes`` (k, n, N, 6) complex or None."""

    spin_rate: np.ndarray
    frequency: np.ndarray
    damping_ratio: np.ndarray
    kind: np.ndarray
    shapes: np.ndarray | None

    def datasets(self) -> dict:
        """The results file's ``/campbell/*`` datasets."""
        return {"campbell/spin_rate": self.spin_rate, "campbell/frequency": self.frequency,
                "campbell/damping_ratio": self.damping_ratio, "campbell/kind": self.kind.astype(str)}

    def table(self) -> list[str]:
        """Spin rate and the frequencies [Hz], then the largest |damping ratio| and the unstable modes: a damping
        ratio below ``−UNSTABLE_DAMPING`` (:data:`reference.modal.UNSTABLE_DAMPING`, relative to the root) is
        unstable, within ``±UNSTABLE_DAMPING`` the roots are imaginary to round-off (undamped)."""
        from reference.modal import UNSTABLE_DAMPING

        n = self.frequency.shape[1]
        lines = [f"{'spin rate [rad/s]':>17}  " + "  ".join(f"{'mode ' + str(j + 1) + ' [Hz]':>13}" for j in range(n))]
        for rate, f in zip(self.spin_rate, self.frequency):
            lines.append(f"{rate:>17.6g}  " + "  ".join(f"{x:>13.6g}" for x in f))
        zeta = float(np.max(np.abs(self.damping_ratio)))
        unstable = int(np.sum(self.kind == "unstable"))
        lines.append(f"largest |damping ratio| {zeta:.2g}"
                     + (f" (below {UNSTABLE_DAMPING:g}: undamped, imaginary roots)" if zeta <= UNSTABLE_DAMPING else "")
                     + f"; unstable modes (damping ratio below -{UNSTABLE_DAMPING:g}): {unstable}")
        return lines


def parse_rates(text: str) -> np.ndarray:
    """``"START:STOP:N"`` → N equally spaced spin rates [rad/s] (N ≥ 2; START = STOP allowed with N = 1).
    Raises ValueError with the fix."""
    parts = text.split(":")
    try:
        if len(parts) != 3:
            raise ValueError
        start, stop, n = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise ValueError(f"--rates {text!r}: expected START:STOP:N, e.g. --rates 0:12:13 (13 rates from 0 to "
                         "12 rad/s)") from None
    if not (np.isfinite(start) and np.isfinite(stop)) or n < 1 or n > 10_000 or (n == 1 and start != stop):
        raise ValueError(f"--rates {text!r}: START and STOP finite, N from 1 to 10000 (N = 1 only with START = "
                         "STOP), e.g. --rates 0:12:13")
    return np.linspace(start, stop, n)


def campbell(domain, rates, n: int | None = None, shapes: bool = False) -> Campbell:
    """The ``n`` lowest modes (default the deck's ``modes``) of ``domain`` spinning about its solver's
    ``spin_axis`` through ``spin_point`` at each of ``rates`` [rad/s]; ``shapes`` keeps the mode shapes
    (per node, :meth:`reference.algorithms.linearization.Linearization.nodal`)."""
    from reference.algorithms.linearization import at_steady_rotation, mobility, reduce
    from reference.algorithms.implicit import NewtonSystem
    from reference.modal import modes

    settings = domain.solver
    n = int(n or settings.modes)
    model, state = domain.initialization(), domain.initial_conditions()
    system = NewtonSystem(model)
    rows = []
    for rate in np.asarray(rates, dtype=float):
        lin = at_steady_rotation(model, state, rate, settings.spin_axis, settings.spin_point, system=system)
        state.x[:], state.q[:] = lin.x, lin.q  # the next rate starts from this stretched state
        red = reduce(lin)
        size, asked = red.M.shape[0], min(n + mobility(model, lin), red.M.shape[0])
        found = modes(red.M, red.D, red.K, asked)
        while np.sum(found.kind != "zero") < n and asked < size:
            # more zero modes than rigid-body motions (a direction without stiffness): ask past them, as
            # `flexmbs modes` lists the lowest modes whatever their kind
            asked = min(2 * asked, size)
            found = modes(red.M, red.D, red.K, asked)
        keep = np.flatnonzero(found.kind != "zero")[:n]
        rows.append((found.frequency[keep], found.damping_ratio[keep], found.kind[keep],
                     lin.nodal((red.Z @ found.phi[:, keep]).T) if shapes else None))
    if any(len(r[0]) < n for r in rows):
        worst = min(range(len(rows)), key=lambda k: len(rows[k][0]))
        raise ValueError(f"only {len(rows[worst][0])} modes that are not zero modes at the spin rate "
                         f"{float(np.asarray(rates)[worst]):g} rad/s, {n} asked; ask for at most "
                         f"{len(rows[worst][0])} modes")
    f, zeta, kind, phi = zip(*rows)
    return Campbell(np.asarray(rates, dtype=float), np.array(f), np.array(zeta), np.array(kind),
                    np.array(phi) if shapes else None)


def write(results_path, table: Campbell) -> None:
    """Add the ``/campbell/*`` datasets to a results file (replacing earlier ones)."""
    import h5py

    with h5py.File(results_path, "r+") as f:
        for path, value in table.datasets().items():
            if path in f:
                del f[path]
            value = np.asarray(value)
            f.create_dataset(path, data=value.astype(h5py.string_dtype()) if value.dtype.kind == "U" else value)


def figure(table: Campbell, path, title: str) -> None:
    """The Campbell diagram: each mode's frequency [Hz] against the spin rate, with the 1P and 2P lines
    (``f = Ω/2π``, ``2Ω/2π``: the excitations once and twice per revolution)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmbs.plot import save_figure

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for j in range(table.frequency.shape[1]):
        ax.plot(table.spin_rate, table.frequency[:, j], "o-", ms=3, label=f"mode {j + 1}")
    for k in (1, 2):
        ax.plot(table.spin_rate, k * np.abs(table.spin_rate) / (2 * np.pi), ":", color="0.5")
        ax.annotate(f"{k}P", (table.spin_rate[-1], k * abs(table.spin_rate[-1]) / (2 * np.pi)), fontsize=7)
    ax.set_xlabel("spin rate Ω [rad/s]")
    ax.set_ylabel("frequency [Hz] (spinning frame)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)
    save_figure(fig, path)
    plt.close(fig)
