"""Local refinement of the scan's answer in (u, v): where it starts (starts.py: the scan's seeds,
contour crossings, rings around the CC point, seams), the batched model steps (steps.py) on the
exact sizes of surface points (objective.py), the one-dimensional search along the bottom-plane
contour (contour_walk.py), the curvature limit at the CC point in closed form (limits.py), and
the rows' best answer that each of them lowers (best.py)."""
