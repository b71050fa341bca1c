"""Where the test points lie for each CC row, in its tool frame: the tool frames and the rows
grouped by axis (frames.py), the cell grid of the test points and the rows' trial regions in it
(candidates.py), grids shared by rows of nearby axes (bins.py), and the sound bounds on where a
point of small size can lie that the regions are built from (family.py)."""
