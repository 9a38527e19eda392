# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # Lesson 5 — Cross-checking with Exudyn
#
# An independent code is the strongest check short of an analytic solution. The harness
# translates the deck item by item into Exudyn (its geometrically exact beam, rigid bodies,
# generic joints) and compares the two results files. The two codes' beam elements differ
# (lumped vs consistent mass, another rotation interpolation), so the tolerances depend on
# the observable: the rocker angle is mesh-insensitive, the coupler deflection is not.

# %%
import os
from pathlib import Path
import tempfile

from crosscheck.harness import run

import reference

QUICK = os.environ.get("FLEXMBS_QUICK") == "1"
# the repository, wherever the notebook runs from (the editable install points here)
ROOT = Path(reference.__file__).resolve().parents[1]
with tempfile.TemporaryDirectory() as out:
    cmp = run(ROOT / "models/three_bar.toml", out, t_end=2.0 if QUICK else 10.0)
for v in cmp["verdicts"]:
    print(f"{v.observable}: {v.measure:.3e} (tolerance {v.tolerance:g}, relative to {v.relative_to})")
print("max ‖Φ‖: reference %.1e, Exudyn %.1e" % (cmp["drift"]["a"]["violation_max"], cmp["drift"]["b"]["violation_max"]))
rocker = next(v for v in cmp["verdicts"] if v.observable == "rocker_angle")
assert rocker.max_difference < 2e-4
