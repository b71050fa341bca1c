"""Flank milling (Gong and Wang 2009): the envelope of a cutter of revolution moved
along a 5-axis path, its error to the design surface along the envelope's normal, and the
least-squares adjustment of the tool-axis trajectory. Part frame, mm; docs/MATH.md §12."""
