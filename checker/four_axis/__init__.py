"""4-axis: best table angle B per CC point, feasible B intervals, orientation along the
path (the plan of an operation; the real tool along what is written is `checker.verify`)."""
