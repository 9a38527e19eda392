"""Cross-check harness: the same models in Exudyn; comparison of trajectories and constraint drift."""
