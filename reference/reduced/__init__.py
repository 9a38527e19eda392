"""Reduced flexible bodies: a beam described by a floating reference frame plus a few modes (issue 39).

:mod:`reference.reduced.craig_bampton` makes the modes from the project's own linearisation of a meshed beam
(fixed-interface normal modes plus constraint modes, or free-free modes) and the floating-frame invariants.
"""
