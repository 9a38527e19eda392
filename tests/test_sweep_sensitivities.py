"""``flexmbs sweep`` with ``sensitivities = true`` (flexmbs/sweep_sensitivities.py, issue 40): every case
carries the deck's ``[sensitivities]``, and the summary's derivative agrees with the finite difference
between neighbouring cases of the grid."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import h5py
import pytest

from flexmbs.sweep import load_study, run_case
from reference.io.deck import DeckError

ROOT = Path(__file__).resolve().parent.parent
TIP = "position:beam:end"
EI = [99.9, 100.0, 100.1]
"""The grid of the roll-up's EI2 (the moment stays 2π·100/L: the tip's curve k = M L/(π EI) moves with EI)."""


def _deck(tmp_path) -> Path:
    """The static roll-up to k = 1 in 10 load steps on the reference path, with a [sensitivities] table."""
    text = (ROOT / "models" / "embedded_beam_static.toml").read_text()
    text = text.replace("t_end = 2.0 ", "t_end = 1.0 ").replace("load_steps = 20 ", "load_steps = 10 ")
    text = text.replace("[solver]\n", '[solver]\nbackend = "reference"\n')
    text += f'\n[sensitivities]\nparameters = ["sections.rollup.EI2", "loads[0].moment"]\noutputs = ["{TIP}"]\n'
    path = tmp_path / "rollup.toml"
    path.write_text(text)
    return path


def _study(tmp_path, extra="sensitivities = true") -> Path:
    path = tmp_path / "study.toml"
    path.write_text(f'deck = "{_deck(tmp_path).name}"\n{extra}\n[grid]\n"sections.rollup.EI2" = {EI}\n')
    return path


def test_study_sensitivities_agree_with_the_grid_neighbours(tmp_path):
    study = load_study(_study(tmp_path))
    assert study.sensitivities
    rows = [run_case(study.deck, {"sections.rollup.EI2": ei}, tmp_path / f"case_{k}", True)
            for k, ei in enumerate(EI)]
    assert [r["status"] for r in rows] == ["completed"] * 3
    name = f"sensitivity.{TIP}.sections.rollup.EI2"
    for c in ("x", "z"):
        for a, b in zip(rows, rows[1:]):
            step = b["sections.rollup.EI2"] - a["sections.rollup.EI2"]
            difference = (b[f"output.{TIP}.{c}"] - a[f"output.{TIP}.{c}"]) / step
            mean = 0.5 * (a[f"{name}.{c}"] + b[f"{name}.{c}"])
            # the secant between neighbours equals the mean of the end slopes to O(step² f''') (trapezoid
            # rule): the exact circle's tip (x, z) = L (sin πk, 1 − cos πk)/(πk), k = 100/EI, gives 0.8e-6 and
            # 1.2e-6 of the slope at steps of 0.1 (1.2e-4 at steps of 1, as measured here too); Newton's
            # tolerance leaves about 1e-7 in the difference.  Bound 1e-5 of the slope.
            assert abs(difference - mean) <= 1e-5 * abs(mean)
    with h5py.File(rows[1]["results"], "r") as f:  # the results file has what `flexmbs run` writes
        assert f[f"sensitivities/{TIP}/sections.rollup.EI2"][-1][0] == rows[1][f"{name}.x"]
        assert "sensitivities/load_factor" in f
    # the tip's scale sensitivity is that of the moment: ds = −dEI/EI along the curve k = M L/(π EI)
    # (the deck's EI = 100 case: d/ds = −EI d/dEI, exactly, since the tip depends on M/EI only)
    mid = rows[1]
    for c in ("x", "z"):
        assert abs(mid[f"sensitivity.{TIP}.loads[0].moment.{c}"] + 100.0 * mid[f"{name}.{c}"]) <= \
            1e-8 * abs(mid[f"sensitivity.{TIP}.loads[0].moment.{c}"])


def test_a_study_without_the_deck_table_or_with_a_bad_flag_is_one_line(tmp_path):
    path = _study(tmp_path, "sensitivities = 1")
    with pytest.raises(DeckError, match=r"study\.toml: sensitivities: expected true or false, got 1; write") as e:
        load_study(path)
    assert "\n" not in str(e.value)
    path, deck = _study(tmp_path), tmp_path / "rollup.toml"
    deck.write_text(deck.read_text().split("[sensitivities]")[0])
    with pytest.raises(DeckError, match=r"sensitivities: the deck rollup\.toml has no \[sensitivities\] table; add"):
        load_study(path)


def test_the_summary_of_a_cluster_study_has_the_sensitivity_columns(tmp_path):
    pytest.importorskip("dask.distributed")
    from flexmbs.sweep import run_study

    study = load_study(_study(tmp_path))
    run_study(study, tmp_path / "out", workers=1, progress=lambda line: None)
    with open(tmp_path / "out" / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["status"] for r in rows] == ["completed"] * 3
    serial = run_case(study.deck, {"sections.rollup.EI2": EI[0]}, tmp_path / "serial", True)
    column = f"sensitivity.{TIP}.sections.rollup.EI2.z"
    assert float(rows[0][column]) == serial[column]  # same code, same machine; the CSV keeps 17 digits


def test_a_modes_study_gives_the_frequencies_and_their_derivatives(tmp_path):
    text = (ROOT / "models" / "cantilever_modes.toml").read_text()
    text = re.sub(r"(?m)^backend = .*\n", "", text).replace("[solver]\n", '[solver]\nbackend = "reference"\n')
    (tmp_path / "modes.toml").write_text(text + '\n[sensitivities]\nparameters = ["sections.rect.EI2"]\n')
    study = tmp_path / "study.toml"
    study.write_text('deck = "modes.toml"\nsensitivities = true\n[grid]\n"sections.rect.EI2" = [0.999, 1.001]\n')
    deck = load_study(study).deck
    a, b = (run_case(deck, {"sections.rect.EI2": ei}, tmp_path / f"case_{ei}", True) for ei in (0.999, 1.001))
    assert a["status"] == b["status"] == "completed"
    secant = (b["frequency.1"] - a["frequency.1"]) / 0.002
    mean = 0.5 * (a["sensitivity.frequency.sections.rect.EI2.1"] + b["sensitivity.frequency.sections.rect.EI2.1"])
    # f ∝ EI^(1/2) to the shear's 1e-3: the secant's trapezoid error (1e-3)²/12 · 3/4 = 6e-8 of the slope, the
    # frequencies' round-off 4e-10 / 2e-3 = 2e-7 of it: bound 2e-6
    assert abs(secant - mean) <= 2e-6 * abs(mean)
    assert "sensitivity.frequency.sections.rect.EI2.10" in a  # every mode of the deck's 10
