"""The global scan: the exact minimum of the imaginary size over all test points of each CC row
with sound pruning (search.py), from upper bounds (bound.py) and single passes over the cell
grid (sweep.py), which also give the seeds of the local refinement: sampled local minima
(basins.py) and, for flat-bottomed cutters, crossings of the bottom-plane contour (contour.py)."""
