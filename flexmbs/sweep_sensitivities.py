"""A study's sensitivities (``sensitivities = true`` in a study file, :mod:`flexmbs.sweep`): the deck's own
``[sensitivities]`` table differentiated at every case of the grid.

Each case gets what ``flexmbs run`` writes for the deck (``/sensitivities/…`` in its results file,
:func:`reference.io.deck_sensitivities.sensitivity_datasets`, docs/results.md), computed with the case's
overrides, and its summary row gets, at the final load level or time, every output's value and its
derivative with respect to every parameter:

- static and generalized-α: ``output.OUTPUT`` and ``sensitivity.OUTPUT.PARAMETER`` (a vector's components
  ``….x``, ``….y``, … as the checks' columns);
- modes: ``frequency.K`` [Hz] and ``sensitivity.frequency.PARAMETER.K`` (df/dp), K = 1 … the modes asked;
- buckling: ``load_factor.K`` and ``sensitivity.load_factor.PARAMETER.K`` (dμ/dp).

So a grid over one of the parameters shows the derivative beside the finite difference between
neighbouring cases, ``(value[k+1] − value[k]) / (p[k+1] − p[k])``: the two agree to the difference's own
truncation error (half the step times the second derivative), a check any user can make from the summary.
"""

from __future__ import annotations

import numpy as np

EIGEN = {"modes": ("frequency", "modes/frequency"), "buckling": ("load_factor", "buckling/load_factor")}
"""Per eigenvalue algorithm: the summary's name of its eigenvalues and their dataset in the results file."""


def dataset_key(text: str) -> str:
    """An output or parameter name as a dataset name of ``/sensitivities`` (``/`` is written ``|``, docs/results.md)."""
    return text.replace("/", "|")


def sensitivity_values(read, deck_path, overrides: dict, results, results_path, columns) -> dict:
    """The case's sensitivities: append them to its results file and return its summary columns
    (module docstring).

    Parameters
    ----------
    read : Deck
        The case's deck (:func:`reference.io.deck.load_deck` with ``overrides``), with its ``sensitivities``.
    deck_path : path-like
        The deck file (the sensitivities read it again with ``overrides``).
    overrides : dict
        The case's overrides of the deck reader.
    results : Results
        The case's run (its final output values, its eigenvalues).
    results_path : path-like
        Its results file, which gets ``/sensitivities/…``.
    columns : callable(out, column, value, kind)
        Writes a value into the row as the checks' columns are written (:func:`flexmbs.sweep.add_columns`).

    Raises
    ------
    ValueError
        One line (:class:`reference.io.deck_parameters.ParameterError` and the observables' errors are
        ValueErrors): the case's row is then failed with it.
    """
    from reference.io.deck_sensitivities import sensitivity_datasets
    from reference.io.results import append_datasets
    from reference.observables import parse

    table = read.sensitivities
    datasets = sensitivity_datasets(deck_path, table, overrides)
    append_datasets(results_path, datasets)
    out: dict = {}
    algorithm = read.domain.solver.algorithm
    if algorithm in EIGEN:
        name, path = EIGEN[algorithm]
        values = np.asarray(results.data(path), dtype=float)
        out.update({f"{name}.{k + 1}": float(v) for k, v in enumerate(values)})
        for p in table["parameters"]:
            d = datasets[f"sensitivities/{name}/{dataset_key(p)}"]
            out.update({f"sensitivity.{name}.{p}.{k + 1}": float(v) for k, v in enumerate(d)})
        return out
    for text in table.get("outputs", []):
        observable = parse(text, read.domain)
        columns(out, f"output.{text}", np.asarray(observable.evaluate(results), dtype=float)[-1], observable.kind)
        for p in table["parameters"]:
            d = np.asarray(datasets[f"sensitivities/{dataset_key(text)}/{dataset_key(p)}"], dtype=float)[-1]
            columns(out, f"sensitivity.{text}.{p}", d, observable.kind)
    return out
