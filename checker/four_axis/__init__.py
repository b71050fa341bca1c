"""4-axis: best table angle B per CC point, feasible B intervals, orientation along the
path, intermediate poses."""
