"""5-axis: feasible tool orientations per CC point and the tool axis along a path."""
