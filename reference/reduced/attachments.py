"""Where a reduced beam may be attached: its interface nodes (issue 39).

A reduced body keeps exact the motion of its interface nodes (Craig–Bampton keeps their six coordinates each);
a joint, spring, load or master/slave pair at another node of its mesh would act on a point the modes only
approximate, so the deck names that node among the interfaces instead.
"""

from __future__ import annotations

import numpy as np


def _attached(model) -> list[tuple[str, np.ndarray]]:
    """``(what, node ids)`` of everything in ``model`` that acts at nodes: joints, force elements, loads,
    master/slave pairs, prescribed coordinates of ``free`` aside (a clamp of a reduced node is a constraint row)."""
    ms = model.master_slave
    return [("a joint", np.concatenate([model.joints.i, model.joints.j])),
            ("a spring or damper", np.concatenate([model.force_elements.i, model.force_elements.j])),
            ("a load", np.asarray(model.loads.node)),
            ("a master/slave joint", np.concatenate([np.ravel(ms.master), np.ravel(ms.slave)]))]


def attachment_problem(model, beams: dict, labels) -> tuple[str, str] | None:
    """``(problem, fix)`` for the first joint, spring, load or master/slave joint of ``model`` at a node of a
    reduced beam that is not one of its interfaces; None when there is none.

    ``beams``: label → ``(node ids along the beam, interface positions along it)``; ``labels`` the node labels
    by id."""
    for label, (nodes, interfaces) in beams.items():
        inner = set(np.asarray(nodes).tolist()) - {int(nodes[k]) for k in interfaces}
        for what, ids in _attached(model):
            hit = next((int(i) for i in np.asarray(ids, dtype=np.int64).tolist() if i in inner), None)
            if hit is not None:
                return (f"{what} acts at node {labels[hit]!r} of reduced beam {label!r}, which is not one of its "
                        "interfaces", f"add {labels[hit]!r} to interfaces, or attach it at an interface node")
        if any(int(i) in inner for i in np.flatnonzero((model.nodes.free < 0.5).any(axis=1))):
            return (f"a clamp or fixed coordinate holds a node of reduced beam {label!r} that is not one of its "
                        "interfaces", "add that node to interfaces")
    return None
